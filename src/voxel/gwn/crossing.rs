//! The exact winding number of a closed chain of triangles at single points: a signed crossing count along
//! the +z ray with exact predicates, for the voxels the rasterizer's count cannot be trusted at (within the
//! near distance of the surface, `super::zone`).
//!
//! The ray from q runs to +∞ along one axis, the one over which the triangles' projected boxes have the
//! least total area (a flat polygon is seen edge-on: its fans index nothing); below, "z" is that axis and
//! (x, y) the two others in cyclic order. A triangle counts when the point lies inside its projection and
//! below its plane, with sign σ = the orientation of its projection (+1 when its normal points up, so a
//! closed outward surface counts +1 inside: the solid-angle convention). Both tests are
//! Shewchuk's adaptive `orient2d`/`orient3d` (the `robust` crate) on the very f64 coordinates the solid
//! angles use. A point exactly on a projected edge or vertex is moved by the symbolic perturbation
//! q + (ε, ε²): the sign of orient2d(a, b, q + (ε, ε²)) is that of orient2d(a, b, q), else of a_y − b_y,
//! else of b_x − a_x. Every edge is then decided the same way for the triangles on both of its sides, so
//! the count of a closed chain is its winding number at the perturbed point, which is the winding number
//! at q unless q lies on a triangle. [`Crossings::winding`] says so with `None` when the triangle's
//! projection has area (orient3d = 0 inside it); triangles whose projection has none never count (their
//! three edge tests cannot agree) and are not indexed: a point on one of those is found by the caller
//! (`super::zone`'s on-surface list), or by the index itself when built with
//! [`Crossings::with_flat_triangles`].
//!
//! Cost: triangles are bucketed by their projected box over a grid of about 16 triangles a cell; a query
//! tests the triangles of its cell (a box test, then at most four predicates). Triangles covering more
//! than [`WIDE`] cells go to one list every query scans.
use rayon::prelude::*;
use robust::{orient2d, orient3d, Coord, Coord3D};

/// Cells a triangle may cover before it goes to the list every query scans.
pub const WIDE: usize = 64;

/// The triangles of a closed chain, bucketed for +z rays.
pub struct Crossings {
    /// The ray axis: coordinates are permuted so that it comes last (a rotation: solid angles are the
    /// same in the permuted frame).
    axis: usize,
    tris: Vec<[[f64; 3]; 3]>,
    sigma: Vec<i8>,
    lo: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    starts: Vec<u32>,
    items: Vec<u32>,
    wide: Vec<u32>,
}

fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// The sign of orient2d(a, b, q + (ε, ε²)).
#[inline]
fn side(a: [f64; 3], b: [f64; 3], q: [f64; 3]) -> i8 {
    let o = orient2d(
        Coord { x: a[0], y: a[1] },
        Coord { x: b[0], y: b[1] },
        Coord { x: q[0], y: q[1] },
    );
    if o != 0.0 {
        sign(o)
    } else if a[1] != b[1] {
        sign(a[1] - b[1])
    } else {
        sign(b[0] - a[0])
    }
}

/// An axis whose projection gives triangle `t` an area (exactly), if any.
fn plane_axis(t: &[[f64; 3]; 3]) -> Option<usize> {
    (0..3).rev().find(|&axis| {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        orient2d(
            Coord {
                x: t[0][u],
                y: t[0][v],
            },
            Coord {
                x: t[1][u],
                y: t[1][v],
            },
            Coord {
                x: t[2][u],
                y: t[2][v],
            },
        ) != 0.0
    })
}

/// Whether `q`, coplanar with (a, b, c), lies in the closed triangle (exactly, in a projection where it
/// has an area).
fn on_triangle(a: [f64; 3], b: [f64; 3], c: [f64; 3], q: [f64; 3]) -> bool {
    let Some(axis) = plane_axis(&[a, b, c]) else {
        return false;
    };
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let o = |p: [f64; 3], r: [f64; 3]| {
        sign(orient2d(
            Coord { x: p[u], y: p[v] },
            Coord { x: r[u], y: r[v] },
            Coord { x: q[u], y: q[v] },
        ))
    };
    let s = sign(orient2d(
        Coord { x: a[u], y: a[v] },
        Coord { x: b[u], y: b[v] },
        Coord { x: c[u], y: c[v] },
    ));
    [o(a, b), o(b, c), o(c, a)]
        .iter()
        .all(|&e| e == 0 || e == s)
}

impl Crossings {
    /// The bucketed chain of `triangles` (local f64 corners).
    pub fn new(given: Vec<[[f64; 3]; 3]>) -> Crossings {
        Crossings::build(given, false)
    }

    /// As [`Crossings::new`], with the triangles whose projection has no area indexed too (they never
    /// count), so that [`Crossings::winding`] answers `None` on every triangle of the chain: what scattered
    /// points need (`api::query`), where no near-zone list finds the points lying on them.
    pub fn with_flat_triangles(given: Vec<[[f64; 3]; 3]>) -> Crossings {
        Crossings::build(given, true)
    }

    fn build(given: Vec<[[f64; 3]; 3]>, flats: bool) -> Crossings {
        // The axis whose projections have the least total box area.
        let area = |axis: usize| -> f64 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            given
                .par_iter()
                .map(|t| {
                    let e = |k: usize| {
                        t.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max)
                            - t.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min)
                    };
                    e(u) * e(v)
                })
                .sum()
        };
        let axis = (0..3)
            .rev()
            .min_by(|&a, &b| area(a).total_cmp(&area(b)))
            .expect("three axes");
        let permute = |p: [f64; 3]| [p[(axis + 1) % 3], p[(axis + 2) % 3], p[axis]];
        let mut triangles = given;
        triangles.par_iter_mut().for_each(|t| *t = t.map(permute));
        let mut sigma = Vec::with_capacity(triangles.len());
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for t in &triangles {
            let s = sign(orient2d(
                Coord {
                    x: t[0][0],
                    y: t[0][1],
                },
                Coord {
                    x: t[1][0],
                    y: t[1][1],
                },
                Coord {
                    x: t[2][0],
                    y: t[2][1],
                },
            ));
            sigma.push(s);
            if s != 0 || flats {
                for v in t {
                    for k in 0..2 {
                        lo[k] = lo[k].min(v[k]);
                        hi[k] = hi[k].max(v[k]);
                    }
                }
            }
        }
        let indexed: Vec<bool> = sigma.iter().map(|&s| s != 0 || flats).collect();
        let counted = indexed.iter().filter(|&&x| x).count();
        let mut c = Crossings {
            axis,
            tris: triangles,
            sigma,
            lo,
            cell: 1.0,
            dims: [1, 1],
            starts: vec![0, 0],
            items: Vec::new(),
            wide: Vec::new(),
        };
        if counted == 0 {
            return c;
        }
        let extent = [(hi[0] - lo[0]).max(0.0), (hi[1] - lo[1]).max(0.0)];
        let cells_wanted = (counted / 16).max(1) as f64;
        let cell = ((extent[0].max(1e-300) * extent[1].max(1e-300)) / cells_wanted)
            .sqrt()
            .max(extent[0].max(extent[1]) / 4096.0)
            .max(1e-300);
        let dims = [
            ((extent[0] / cell).floor() as usize + 1).min(4096),
            ((extent[1] / cell).floor() as usize + 1).min(4096),
        ];
        c.cell = cell;
        c.dims = dims;
        let index = |offset: f64, k: usize| -> usize {
            ((offset / cell).floor().max(0.0) as usize).min(dims[k] - 1)
        };
        let range = |t: &[[f64; 3]; 3], k: usize| {
            let a = t.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
            let b = t.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max);
            (index(a - lo[k], k), index(b - lo[k], k))
        };
        let mut counts = vec![0u32; dims[0] * dims[1] + 1];
        for (i, t) in c.tris.iter().enumerate() {
            if !indexed[i] {
                continue;
            }
            let ((x0, x1), (y0, y1)) = (range(t, 0), range(t, 1));
            if (x1 - x0 + 1) * (y1 - y0 + 1) > WIDE {
                c.wide.push(i as u32);
                continue;
            }
            for y in y0..=y1 {
                for x in x0..=x1 {
                    counts[y * dims[0] + x + 1] += 1;
                }
            }
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        c.items = vec![0; counts[counts.len() - 1] as usize];
        for (i, t) in c.tris.iter().enumerate() {
            if !indexed[i] {
                continue;
            }
            let ((x0, x1), (y0, y1)) = (range(t, 0), range(t, 1));
            if (x1 - x0 + 1) * (y1 - y0 + 1) > WIDE {
                continue;
            }
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let slot = &mut fill[y * dims[0] + x];
                    c.items[*slot as usize] = i as u32;
                    *slot += 1;
                }
            }
        }
        c.starts = counts;
        c
    }

    /// The winding number at `q` of the chain's first `count` triangles by the plain sum of their solid
    /// angles, in order (the decision of last resort: with M first, M's own winding number).
    pub fn plain_sum(&self, q: [f64; 3], count: usize) -> f64 {
        super::kernel::winding_sum(&self.tris[..count], self.permute(q))
    }

    fn permute(&self, q: [f64; 3]) -> [f64; 3] {
        let a = self.axis;
        [q[(a + 1) % 3], q[(a + 2) % 3], q[a]]
    }

    /// Bytes held (what the memory budget counts).
    pub fn bytes(&self) -> u64 {
        (self.tris.len() * (std::mem::size_of::<[[f64; 3]; 3]>() + 1)
            + (self.starts.len() + self.items.len() + self.wide.len()) * 4) as u64
    }

    /// The winding number of the chain at `q` (local), or `None` when `q` lies on one of its triangles whose
    /// projection has area (see the module docs for the others).
    pub fn winding(&self, q: [f64; 3]) -> Option<i32> {
        let q = self.permute(q);
        let mut n = 0i32;
        let (x, y) = (q[0] - self.lo[0], q[1] - self.lo[1]);
        let cell = if x < 0.0 || y < 0.0 {
            None
        } else {
            let (cx, cy) = ((x / self.cell).floor(), (y / self.cell).floor());
            (cx < self.dims[0] as f64 && cy < self.dims[1] as f64)
                .then(|| cy as usize * self.dims[0] + cx as usize)
        };
        let bucket = match cell {
            Some(c) => &self.items[self.starts[c] as usize..self.starts[c + 1] as usize],
            None => &[][..],
        };
        for &i in bucket.iter().chain(&self.wide) {
            match self.crosses(i as usize, q) {
                Some(s) => n += s as i32,
                None => return None,
            }
        }
        Some(n)
    }

    /// σ when the +z ray from q crosses triangle `i`, 0 when it does not, `None` when q lies on it.
    #[inline]
    fn crosses(&self, i: usize, q: [f64; 3]) -> Option<i8> {
        let [a, b, c] = self.tris[i];
        let s = self.sigma[i];
        // Box test first (inclusive: points on the box's edge go on to the exact tests).
        for k in 0..2 {
            let lo = a[k].min(b[k]).min(c[k]);
            let hi = a[k].max(b[k]).max(c[k]);
            if q[k] < lo || q[k] > hi {
                return Some(0);
            }
        }
        if q[2] > a[2].max(b[2]).max(c[2]) {
            return Some(0);
        }
        let point = |p: [f64; 3]| Coord3D {
            x: p[0],
            y: p[1],
            z: p[2],
        };
        let o = orient3d(point(a), point(b), point(c), point(q));
        if o == 0.0 && on_triangle(a, b, c, q) {
            return None;
        }
        if s == 0 {
            // A flat triangle (indexed only for the test above): the ray never crosses it.
            return Some(0);
        }
        if side(a, b, q) != s || side(b, c, q) != s || side(c, a, q) != s {
            return Some(0);
        }
        // orient3d > 0: q lies on the side its normal points away from; the normal points up when σ > 0.
        if sign(o) * s > 0 {
            Some(s)
        } else {
            Some(0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::kernel::winding_sum;
    use crate::voxel::mesh::TriMesh;

    fn local(m: &TriMesh) -> Vec<[[f64; 3]; 3]> {
        m.triangles
            .iter()
            .map(|t| t.map(|v| m.positions[v as usize].map(|x| x as f64)))
            .collect()
    }

    #[test]
    fn the_crossing_count_of_closed_meshes_is_their_winding_number() {
        let mut mesh = TriMesh::cube([0.0; 3], 1.0);
        let mut inner = TriMesh::cube([0.25; 3], 0.5);
        for t in &mut inner.triangles {
            t.swap(1, 2);
        }
        mesh.append(&inner);
        mesh.append(&TriMesh::sphere([1.0, 0.5, 0.5], 0.4, 6, 9, false));
        let tris = local(&mesh);
        let c = Crossings::new(tris.clone());
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..=12 {
            for j in 0..=12 {
                for k in 0..=12 {
                    // x and y on the lattice of the cubes' edges and vertices: rays along vertical faces,
                    // through edges and vertices, the perturbation's cases.
                    let q = [
                        i as f64 / 8.0 - 0.25,
                        j as f64 / 8.0 - 0.25,
                        k as f64 / 8.0 - 0.3,
                    ];
                    let w = winding_sum(&tris, q);
                    let on = tris.iter().any(|t| {
                        crate::voxel::gwn::kernel::triangle_distance(q, t[0], t[1], t[2]) < 1e-12
                    });
                    // Points on a face seen edge-on along the ray are the caller's to find.
                    match c.winding(q) {
                        Some(n) if !on => {
                            assert!((w - n as f64).abs() < 1e-9, "{q:?}: {n} vs {w}");
                            seen.insert(n);
                        }
                        Some(_) => {}
                        None => assert!(on, "{q:?} said on the surface"),
                    }
                }
            }
        }
        assert!(
            seen.contains(&0) && seen.contains(&1) && seen.contains(&2),
            "{seen:?}"
        );
    }
}
