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
//! tests the triangles of its cell (a box test, then at most four predicates). A triangle covering more
//! than [`WIDE`] cells goes to the first coarser grid (cells 4× wider, then 16×, … up to one cell) where it
//! covers at most that many, so a query tests its cell at each of the O(log) grids: the big triangles of a
//! cap across a polygon of a million sides (which cover the whole disc at every scale of the recursion)
//! cost a query the few whose box holds it, not a list of all of them.
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
    /// The grids, finest first (cells 4× wider each), the last one cell.
    levels: Vec<Level>,
}

/// One grid of buckets over the projected boxes.
struct Level {
    cell: f64,
    dims: [usize; 2],
    /// Bucket `c` is `items[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl Level {
    fn new(cell: f64, extent: [f64; 2]) -> Level {
        Level {
            cell,
            dims: [
                ((extent[0] / cell).floor() as usize + 1).min(4096),
                ((extent[1] / cell).floor() as usize + 1).min(4096),
            ],
            starts: Vec::new(),
            items: Vec::new(),
        }
    }

    /// The cell along axis `k` of an offset from the grid's corner, clamped to the grid.
    fn index(&self, offset: f64, k: usize) -> usize {
        ((offset / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1)
    }

    /// The cells `((x0, x1), (y0, y1))` (inclusive) the projected box of `t` covers, `lo` the grid's corner.
    fn range(&self, t: &[[f64; 3]; 3], lo: [f64; 2]) -> ((usize, usize), (usize, usize)) {
        let span = |k: usize| {
            let a = t.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
            let b = t.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max);
            (self.index(a - lo[k], k), self.index(b - lo[k], k))
        };
        (span(0), span(1))
    }

    /// The bucket of the point at offset (x, y) from the grid's corner: clamped to the grid as the boxes
    /// are (a point past the far side tests the last cell's triangles, whose boxes then reject it), none
    /// before the corner.
    fn bucket(&self, x: f64, y: f64) -> &[u32] {
        if !(x >= 0.0 && y >= 0.0) {
            return &[];
        }
        let c = self.index(y, 1) * self.dims[0] + self.index(x, 0);
        &self.items[self.starts[c] as usize..self.starts[c + 1] as usize]
    }
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

/// The ray axis of the chain made of `parts` (in order), as [`Crossings::new`] picks it: the axis whose
/// projections give the triangles' boxes the least total area.
pub fn ray_axis(parts: &[&[[[f64; 3]; 3]]]) -> usize {
    let area = |axis: usize| -> f64 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        parts
            .iter()
            .map(|part| {
                part.par_iter()
                    .map(|t| {
                        let e = |k: usize| {
                            t.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max)
                                - t.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min)
                        };
                        e(u) * e(v)
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    (0..3)
        .rev()
        .min_by(|&a, &b| area(a).total_cmp(&area(b)))
        .expect("three axes")
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
        let axis = ray_axis(&[&given]);
        let permute = |p: [f64; 3]| [p[(axis + 1) % 3], p[(axis + 2) % 3], p[axis]];
        let mut triangles = given;
        triangles.par_iter_mut().for_each(|t| *t = t.map(permute));
        // Orientations by the exact predicate, on every thread (its slow path is common on a soup's thin
        // ribbons), then the box of the indexed triangles.
        let sigma: Vec<i8> = triangles.par_iter().map(orientation).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (t, &s) in triangles.iter().zip(&sigma) {
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
            levels: Vec::new(),
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
        let mut levels = vec![Level::new(cell, extent)];
        while let Some(last) = levels.last().filter(|l| l.dims != [1, 1]) {
            levels.push(Level::new(last.cell * 4.0, extent));
        }
        // Each triangle's level: the first where it covers at most WIDE cells (the last has one).
        let covered = |l: &Level, t: &[[f64; 3]; 3]| {
            let ((x0, x1), (y0, y1)) = l.range(t, lo);
            (x1 - x0 + 1) * (y1 - y0 + 1)
        };
        let level_of: Vec<u8> = c
            .tris
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                if !indexed[i] {
                    return u8::MAX;
                }
                levels
                    .iter()
                    .position(|l| covered(l, t) <= WIDE)
                    .unwrap_or(levels.len() - 1) as u8
            })
            .collect();
        // Triangle indices grouped by level (in index order within each).
        let mut by_level: Vec<Vec<u32>> = vec![Vec::new(); levels.len()];
        for (i, &l) in level_of.iter().enumerate() {
            if l != u8::MAX {
                by_level[l as usize].push(i as u32);
            }
        }
        for (level, mine) in levels.iter_mut().zip(&by_level) {
            let dims = level.dims;
            let mut counts = vec![0u32; dims[0] * dims[1] + 1];
            for &i in mine {
                let ((x0, x1), (y0, y1)) = level.range(&c.tris[i as usize], lo);
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
            let mut items = vec![0; counts[counts.len() - 1] as usize];
            for &i in mine {
                let ((x0, x1), (y0, y1)) = level.range(&c.tris[i as usize], lo);
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let slot = &mut fill[y * dims[0] + x];
                        items[*slot as usize] = i;
                        *slot += 1;
                    }
                }
            }
            level.starts = counts;
            level.items = items;
        }
        c.levels = levels;
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
            + self
                .levels
                .iter()
                .map(|l| l.starts.len() + l.items.len())
                .sum::<usize>()
                * 4) as u64
    }

    /// The winding number of the chain at `q` (local), or `None` when `q` lies on one of its triangles whose
    /// projection has area (see the module docs for the others).
    pub fn winding(&self, q: [f64; 3]) -> Option<i32> {
        let q = self.permute(q);
        let mut n = 0i32;
        let (x, y) = (q[0] - self.lo[0], q[1] - self.lo[1]);
        for level in &self.levels {
            for &i in level.bucket(x, y) {
                match self.crosses(i as usize, q) {
                    Some(s) => n += s as i32,
                    None => return None,
                }
            }
        }
        Some(n)
    }

    /// σ when the +z ray from q crosses triangle `i`, 0 when it does not, `None` when q lies on it.
    #[inline]
    fn crosses(&self, i: usize, q: [f64; 3]) -> Option<i8> {
        crossing(&self.tris[i], self.sigma[i], q)
    }

    /// The winding number at `q` (local) of the small closed chain `tris` (local corners, not indexed),
    /// counted as [`Crossings::winding`] counts the index: `None` when q lies on one of its triangles, flat
    /// ones included. For a closed chain the count is its winding number wherever it is defined, whatever
    /// the ray's axis.
    pub fn chain_winding(&self, tris: &[[[f64; 3]; 3]], q: [f64; 3]) -> Option<i32> {
        let q = self.permute(q);
        let mut n = 0i32;
        for t in tris {
            let t = t.map(|p| self.permute(p));
            n += crossing(&t, orientation(&t), q)? as i32;
        }
        Some(n)
    }
}

/// The sign of the projection's orientation of `t` (permuted coordinates): σ, 0 for a flat projection.
fn orientation(t: &[[f64; 3]; 3]) -> i8 {
    let c = |k: usize| Coord {
        x: t[k][0],
        y: t[k][1],
    };
    sign(orient2d(c(0), c(1), c(2)))
}

/// σ when the +z ray from q crosses triangle `t` of orientation `s` (permuted coordinates), 0 when it does
/// not, `None` when q lies on it.
#[inline]
fn crossing(t: &[[f64; 3]; 3], s: i8, q: [f64; 3]) -> Option<i8> {
    let [a, b, c] = *t;
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

    /// The crossing counts of `tris` at every point of the lattice `steps` (per axis: count, step, start)
    /// against the plain sum: equal off the surface, `None` only on it (points on a face seen edge-on along
    /// the ray are the caller's to find). The counts seen off the surface.
    fn counts_on_lattice(
        tris: &[[[f64; 3]; 3]],
        steps: [(usize, f64, f64); 3],
    ) -> std::collections::BTreeSet<i32> {
        let c = Crossings::new(tris.to_vec());
        let mut seen = std::collections::BTreeSet::new();
        for i in 0..=steps[0].0 {
            for j in 0..=steps[1].0 {
                for k in 0..=steps[2].0 {
                    let at = |a: usize, n: usize| n as f64 * steps[a].1 + steps[a].2;
                    let q = [at(0, i), at(1, j), at(2, k)];
                    let w = winding_sum(tris, q);
                    let on = tris.iter().any(|t| {
                        crate::voxel::gwn::kernel::triangle_distance(q, t[0], t[1], t[2]) < 1e-12
                    });
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
        seen
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
        // x and y on the lattice of the cubes' edges and vertices: rays along vertical faces, through edges
        // and vertices, the perturbation's cases.
        let seen = counts_on_lattice(
            &local(&mesh),
            [(12, 0.125, -0.25), (12, 0.125, -0.25), (12, 0.125, -0.3)],
        );
        assert!(
            seen.contains(&0) && seen.contains(&1) && seen.contains(&2),
            "{seen:?}"
        );
    }

    #[test]
    fn big_triangles_go_to_coarser_grids_and_still_count_where_they_cover() {
        // A closed drum: an open tube of 4,000 segments (tiny triangles) shut by two fans from the axis (long
        // slivers from the centre to the rim, each covering many cells of the finest grid), and a big box
        // around half of it. The fans must be found from coarser grids at every point they cover.
        let mut mesh = crate::voxel::stress::open_tube(4000);
        let n = 4000u32;
        let (bottom, top) = (mesh.positions.len() as u32, mesh.positions.len() as u32 + 1);
        mesh.positions.push([0.0, 0.0, -0.5]);
        mesh.positions.push([0.0, 0.0, 0.5]);
        for i in 0..n {
            let j = (i + 1) % n;
            mesh.triangles.push([bottom, j, i]);
            mesh.triangles.push([top, n + i, n + j]);
        }
        mesh.append(&TriMesh::cube([0.1, -0.7, -0.7], 1.4));
        let tris = local(&mesh);
        let c = Crossings::new(tris.clone());
        assert!(c.levels.len() > 2 && c.levels.iter().skip(1).any(|l| !l.items.is_empty()));
        let seen = counts_on_lattice(
            &tris,
            [
                (20, 1.0 / 14.0, -0.71),
                (20, 1.0 / 14.0, -0.69),
                (8, 1.0 / 6.0, -0.63),
            ],
        );
        assert!(
            seen.contains(&0) && seen.contains(&1) && seen.contains(&2),
            "{seen:?}"
        );
    }
}
