//! The boundary of a voxel solid as a closed, manifold, consistently oriented polygon mesh: one quad per
//! voxel face between a solid and an empty voxel (voxels outside the grid are empty), normals pointing out of
//! the solid. This is the single-shell alternative to "unsigned distance shell + marching cubes", which
//! doubles the surface: the output's own voxelization at the same grid is the grid (a voxel centre is half a
//! voxel from every quad).
//!
//! Where the solid is not a manifold (two voxels sharing only an edge or a corner; two empty voxels doing
//! the same), the mesh is made one: the solid is read as face-connected (6-connected), so voxels touching
//! only along an edge or at a corner get separate shells, and empty voxels touching only at a corner are
//! likewise kept apart (the solid between them stays one piece). Two mechanisms do it:
//! - *Sheets at lattice points.* Around each of a lattice point's six lattice edges the boundary faces
//!   (0, 2 or 4 of them) are paired, the two of one solid voxel when there are four; the pairs chain the
//!   faces around the point into cycles, the *sheets*, and each sheet gets its own vertex. The sheets of the
//!   256 configurations of a 2×2×2 block are a table built once.
//! - *Midpoints on pinched edges.* A lattice edge with two solid voxels diagonal across it (and two empty)
//!   carries four faces; even with sheets, both ends can be single vertices (the two voxels joined on both
//!   sides), which would leave one edge with four faces. Each such edge gets two midpoint vertices, one per
//!   solid voxel, inserted into that voxel's two faces (which become pentagons or more), so each half of
//!   the edge has two faces. A polygon with a midpoint starts at it, so that fanning it from its first
//!   corner (STL, GLB, most OBJ readers) never adds the pinched edge as a diagonal.
//!
//! A lattice point with one sheet keeps its exact position; each copy of a split point, and each midpoint,
//! moves [`SPLIT_OFFSET`] of a voxel towards its own solid voxels, so that no two vertices coincide and the
//! two sides of a pinch separate; this is far below the half voxel that would change a centre's side.
//!
//! Cost: O(voxels / 32) word operations to count the faces and to find the lattice points on the boundary
//! (a point is examined only when its 8 voxels differ, found by whole 32-bit words), then O(boundary faces ·
//! log) to emit them (a binary search per corner in its lattice column, and per edge for the pinch test),
//! rows of the grid in parallel. Memory: the mesh
//! itself (about 36 bytes per quad: a vertex per quad on a large smooth surface, f64 positions and four u32
//! indices) plus a copy of the packed grid when its bits do not run along z. The worst case is noise: a
//! checkerboard exposes all six faces of half the voxels, 3·X·Y·Z quads, so the quad count is computed
//! first (by popcounts) and a mesh over [`MAX_BOUNDARY_QUADS`] is refused before anything is allocated.
use super::grid::{Axis, VoxelGrid};
use crate::error::{Error, Result};
use crate::mesh::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::OnceLock;

/// How far, in voxels, a split vertex moves towards its sheet's solid voxels.
pub const SPLIT_OFFSET: f64 = 1.0 / 64.0;

/// Most quads a boundary mesh may have (about 9 GB of mesh); a larger one is refused with its count.
pub const MAX_BOUNDARY_QUADS: u64 = 1 << 28;

/// The sheets of one 2×2×2 configuration around a lattice point.
///
/// Block voxel `b = dx + 2·dy + 4·dz` is voxel `(i − 1 + dx, j − 1 + dy, k − 1 + dz)` of lattice point
/// (i, j, k); configuration bit `b` is set when that voxel is solid. The 12 faces inside the block are
/// numbered `4·a + packed` for the face between `b` and `b | 1 << a` (bit `a` of `b` clear), `packed`
/// being `b`'s two other bits, lower axis first.
#[derive(Clone, Copy, Debug, Default)]
struct Sheets {
    /// Number of sheets (0 when the 8 voxels agree; at most 4).
    count: u8,
    /// The sheet of each boundary face (undefined for the others).
    of_face: [u8; 12],
    /// Each sheet's vertex offset from the lattice point, in voxels (zero when there is one sheet).
    offset: [[f64; 3]; 4],
}

/// The face number of the face between block voxels `b` and `b | 1 << a` (bit `a` of `b` clear).
fn face_index(a: usize, b: usize) -> usize {
    let packed = match a {
        0 => (b >> 1) & 3,
        1 => (b & 1) | ((b >> 2) & 1) << 1,
        _ => b & 3,
    };
    4 * a + packed
}

fn sheets_of(config: u8) -> Sheets {
    let solid = |b: usize| config >> b & 1 == 1;
    // Faces: (axis, lower voxel) for the 12 faces, by face number.
    let mut faces = [(0usize, 0usize); 12];
    for a in 0..3 {
        for b in (0..8).filter(|b| b >> a & 1 == 0) {
            faces[face_index(a, b)] = (a, b);
        }
    }
    let boundary: [bool; 12] = std::array::from_fn(|f| {
        let (a, b) = faces[f];
        solid(b) != solid(b | 1 << a)
    });
    let mut parent: [usize; 12] = std::array::from_fn(|f| f);
    fn find(parent: &mut [usize; 12], mut f: usize) -> usize {
        while parent[f] != f {
            parent[f] = parent[parent[f]];
            f = parent[f];
        }
        f
    }
    // Around the lattice edge along axis e on side s: the four faces whose lower voxel has bit e = s and
    // whose axis is not e.
    for e in 0..3 {
        for s in 0..2 {
            let ring: Vec<usize> = (0..12)
                .filter(|&f| {
                    let (a, b) = faces[f];
                    a != e && (b >> e & 1) == s && boundary[f]
                })
                .collect();
            let pairs: Vec<(usize, usize)> = match ring.len() {
                2 => vec![(ring[0], ring[1])],
                4 => {
                    // Two solid voxels diagonal across the edge: each keeps its own two faces.
                    let solid_of = |f: usize| {
                        let (a, b) = faces[f];
                        if solid(b) {
                            b
                        } else {
                            b | 1 << a
                        }
                    };
                    let mut out = Vec::new();
                    for (x, &f) in ring.iter().enumerate() {
                        for &g in &ring[x + 1..] {
                            if solid_of(f) == solid_of(g) {
                                out.push((f, g));
                            }
                        }
                    }
                    out
                }
                n => {
                    debug_assert_eq!(
                        n, 0,
                        "a ring of four voxels changes side an even number of times"
                    );
                    Vec::new()
                }
            };
            for (f, g) in pairs {
                let (rf, rg) = (find(&mut parent, f), find(&mut parent, g));
                parent[rf] = rg;
            }
        }
    }
    let mut sheets = Sheets::default();
    let mut root_sheet = [u8::MAX; 12];
    let mut solid_sum = [[0.0f64; 3]; 4];
    let mut empty_sum = [[0.0f64; 3]; 4];
    for f in (0..12).filter(|&f| boundary[f]) {
        let r = find(&mut parent, f);
        if root_sheet[r] == u8::MAX {
            root_sheet[r] = sheets.count;
            sheets.count += 1;
        }
        let s = root_sheet[r];
        sheets.of_face[f] = s;
        let (a, b) = faces[f];
        let (inside, outside) = if solid(b) {
            (b, b | 1 << a)
        } else {
            (b | 1 << a, b)
        };
        for (sum, v) in [
            (&mut solid_sum[s as usize], inside),
            (&mut empty_sum[s as usize], outside),
        ] {
            for (c, x) in sum.iter_mut().enumerate() {
                *x += (v >> c & 1) as f64 - 0.5;
            }
        }
    }
    if sheets.count > 1 {
        for s in 0..sheets.count as usize {
            // Towards the sheet's solid voxels; away from its empty ones when those balance out.
            let mut d = solid_sum[s];
            if d.iter().map(|x| x * x).sum::<f64>() < 1e-12 {
                d = empty_sum[s].map(|x| -x);
            }
            let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
            sheets.offset[s] = d.map(|x| x / n * SPLIT_OFFSET);
        }
    }
    sheets
}

/// The sheet table of the 256 configurations.
fn table() -> &'static [Sheets; 256] {
    static TABLE: OnceLock<[Sheets; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|c| sheets_of(c as u8)))
}

/// The boundary lattice points of one lattice row (fixed j): per lattice column i, the heights k whose
/// configuration is mixed, with that configuration and the row-local index of its first vertex; and the
/// row's pinched lattice edges (four boundary faces around them), keyed by their lower end.
#[derive(Default)]
struct Row {
    /// Lattice column i holds entries `starts[i]..starts[i + 1]`.
    starts: Vec<u32>,
    heights: Vec<u32>,
    configs: Vec<u8>,
    first_vertex: Vec<u32>,
    /// Pinched edges by [`edge_key`], ascending, each with the row-local index of its first of two
    /// midpoint vertices.
    pinched: Vec<u64>,
    pinched_vertex: Vec<u32>,
    vertices: u32,
}

/// The key of the lattice edge from (i, ·, k) along axis `a` within a row: ascending in (i, k, a).
fn edge_key(i: u32, k: u32, a: usize) -> u64 {
    (i as u64) << 40 | (k as u64) << 8 | a as u64
}

/// The other two axes of `a`, lower first.
fn across(a: usize) -> (usize, usize) {
    match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Of the four block voxels around the lattice edge from the block's centre along +a (those with bit `a`
/// set), numbered q = du + 2·dv over the two other axes: when the edge is pinched (two solid voxels
/// diagonal across it, two empty), the lower-numbered solid one (0 or 1); otherwise None.
fn pinched_edge(config: u8, a: usize) -> Option<usize> {
    let (u, v) = across(a);
    let solid = |q: usize| config >> ((1 << a) | (q & 1) << u | (q >> 1) << v) & 1 == 1;
    (solid(0) == solid(3) && solid(1) == solid(2) && solid(0) != solid(1)).then(|| {
        if solid(0) {
            0
        } else {
            1
        }
    })
}

/// The packed grid with bits along z, read with zeros outside it.
struct Columns<'a> {
    grid: Cow<'a, VoxelGrid>,
    dims: [u32; 3],
    words: usize,
    /// The column outside the grid.
    zeros: Vec<u32>,
}

/// Word `w` of a column (zero past its end: lattice columns have one bit more than voxel columns).
#[inline]
fn at(c: &[u32], w: usize) -> u32 {
    c.get(w).copied().unwrap_or(0)
}

/// Word `w` of a column shifted up by one bit: bit k is voxel k − 1.
#[inline]
fn below(c: &[u32], w: usize) -> u32 {
    let lo = if w == 0 { 0 } else { at(c, w - 1) >> 31 };
    at(c, w) << 1 | lo
}

impl Columns<'_> {
    /// Voxel column (i, j), all zeros outside the grid.
    #[inline]
    fn col(&self, i: i64, j: i64) -> &[u32] {
        if i < 0 || j < 0 || i >= self.dims[0] as i64 || j >= self.dims[1] as i64 {
            return &self.zeros;
        }
        self.grid.column(i as u32, j as u32)
    }

    /// Whether voxel (i, j, k) is solid (false outside the grid).
    #[inline]
    fn solid(&self, i: i64, j: i64, k: i64) -> bool {
        k >= 0
            && k < self.dims[2] as i64
            && at(self.col(i, j), k as usize / 32) >> (k % 32) & 1 == 1
    }

    /// The configuration of lattice point (i, j, k).
    fn config(&self, i: i64, j: i64, k: i64) -> u8 {
        let mut c = 0u8;
        for b in 0..8 {
            if self.solid(i - 1 + (b & 1), j - 1 + (b >> 1 & 1), k - 1 + (b >> 2 & 1)) {
                c |= 1 << b;
            }
        }
        c
    }

    /// Lattice words of a lattice column (bits 0..=Z).
    fn lattice_words(&self) -> usize {
        (self.dims[2] as usize + 1).div_ceil(32)
    }
}

/// The number of boundary faces owned by lattice row j (as [`row_quads`] visits them), by popcounts.
fn row_quad_count(cols: &Columns, j: i64) -> u64 {
    let [nx, ny, _] = cols.dims.map(|d| d as i64);
    let mut n = 0u64;
    for i in 0..=nx {
        let here = cols.col(i, j);
        if i < nx && j < ny {
            n += (0..cols.lattice_words())
                .map(|w| (at(here, w) ^ below(here, w)).count_ones() as u64)
                .sum::<u64>();
        }
        if j < ny {
            let left = cols.col(i - 1, j);
            n += (0..cols.words)
                .map(|w| (left[w] ^ here[w]).count_ones() as u64)
                .sum::<u64>();
        }
        if i < nx {
            let front = cols.col(i, j - 1);
            n += (0..cols.words)
                .map(|w| (front[w] ^ here[w]).count_ones() as u64)
                .sum::<u64>();
        }
    }
    n
}

/// The boundary mesh of `grid` (see the module docs): quads, outward, in world coordinates.
///
/// ```
/// use gregvox::voxel::{boundary::boundary_mesh, grid::{Axis, GridFrame, VoxelGrid}};
/// let mut g = VoxelGrid::empty(GridFrame::cubic(3, [0.0; 3], 3.0), Axis::Z);
/// g.set(1, 1, 1, true);
/// let cube = boundary_mesh(&g).unwrap();
/// assert_eq!((cube.positions.len(), cube.n_faces()), (8, 6));
/// g.set(2, 2, 1, true); // touches the first along an edge only: two separate cubes, the shared edge's
/// // ends split (8 corners each) and a midpoint on it for each cube
/// assert_eq!(boundary_mesh(&g).unwrap().positions.len(), 18);
/// ```
pub fn boundary_mesh(grid: &VoxelGrid) -> Result<Mesh> {
    let cols = Columns {
        grid: if grid.bit_axis == Axis::Z {
            Cow::Borrowed(grid)
        } else {
            Cow::Owned(grid.to_axis(Axis::Z))
        },
        dims: grid.frame.dims,
        words: grid.frame.words_per_column(Axis::Z) as usize,
        zeros: vec![0; grid.frame.words_per_column(Axis::Z) as usize],
    };
    let [nx, ny, _] = cols.dims.map(|d| d as i64);
    let quads_per_row: Vec<u64> = (0..=ny)
        .into_par_iter()
        .map(|j| row_quad_count(&cols, j))
        .collect();
    let quads: u64 = quads_per_row.iter().sum();
    if quads > MAX_BOUNDARY_QUADS {
        return Err(Error::Invalid(format!(
            "the solid's boundary has {quads} voxel faces, more than the {MAX_BOUNDARY_QUADS} a boundary \
             mesh may have (a noise-like grid); use a voxel format instead"
        )));
    }
    let rows: Vec<Row> = (0..=ny)
        .into_par_iter()
        .map(|j| boundary_points(&cols, j))
        .collect();
    let mut row_base = Vec::with_capacity(rows.len());
    let mut vertices = 0u64;
    for r in &rows {
        row_base.push(vertices as u32);
        vertices += r.vertices as u64;
    }
    if vertices > u32::MAX as u64 {
        return Err(Error::Invalid(format!(
            "the solid's boundary has {vertices} vertices, more than 32-bit indices hold"
        )));
    }
    let frame = &grid.frame;
    let h = DVec3::from(frame.voxel_size);
    let origin = DVec3::from(frame.origin);
    let sheets = table();
    let mut positions = vec![DVec3::ZERO; vertices as usize];
    let mut chunks = Vec::with_capacity(rows.len());
    let mut rest = positions.as_mut_slice();
    for r in &rows {
        let (head, tail) = rest.split_at_mut(r.vertices as usize);
        chunks.push(head);
        rest = tail;
    }
    chunks
        .into_par_iter()
        .zip(rows.par_iter())
        .enumerate()
        .for_each(|(j, (out, row))| {
            for i in 0..=nx as usize {
                for e in row.starts[i] as usize..row.starts[i + 1] as usize {
                    let s = &sheets[row.configs[e] as usize];
                    let p = DVec3::new(i as f64, j as f64, row.heights[e] as f64);
                    for x in 0..s.count as usize {
                        out[row.first_vertex[e] as usize + x] =
                            origin + h * (p + DVec3::from(s.offset[x]));
                    }
                }
            }
            // Two midpoints per pinched edge, each moved towards its own solid voxel.
            for (&key, &first) in row.pinched.iter().zip(&row.pinched_vertex) {
                let (i, k, a) = (
                    (key >> 40) as f64,
                    (key >> 8 & 0xFFFF_FFFF) as f64,
                    key as usize & 3,
                );
                let (u, v) = across(a);
                let mut mid = DVec3::new(i, j as f64, k);
                mid[a] += 0.5;
                // The solid pair is q ∈ {0, 3} or {1, 2}: voxel q sits at (du, dv) − ½ from the edge.
                let lower = {
                    let config = config_at(&rows[j], i as u32, k as u32);
                    pinched_edge(config, a).expect("listed as pinched")
                };
                for (x, q) in [lower, 3 - lower].into_iter().enumerate() {
                    let mut d = DVec3::ZERO;
                    d[u] = (q & 1) as f64 - 0.5;
                    d[v] = (q >> 1) as f64 - 0.5;
                    out[first as usize + x] = origin + h * (mid + d.normalize() * SPLIT_OFFSET);
                }
            }
        });
    // The vertex of lattice point (i, j, k) on the sheet that block face `face` belongs to.
    let vertex = |i: i64, j: i64, k: u32, face: usize| -> u32 {
        let row = &rows[j as usize];
        let e = row.entry(i as u32, k);
        row_base[j as usize]
            + row.first_vertex[e]
            + sheets[row.configs[e] as usize].of_face[face] as u32
    };
    // The midpoint of pinched edge (lower end (i, j, k), axis a) on the side of solid voxel `q` (numbered
    // as in `pinched_edge`).
    let midpoint = |i: i64, j: i64, k: i64, a: usize, q: usize| -> u32 {
        let row = &rows[j as usize];
        let e = row
            .pinched
            .binary_search(&edge_key(i as u32, k as u32, a))
            .expect("a pinched edge is listed at its lower end");
        let lower = if q == 0 || q == 3 { 0 } else { 1 };
        row_base[j as usize] + row.pinched_vertex[e] + (q != lower) as u32
    };
    let polygons: Vec<(Vec<u32>, Vec<u32>)> = (0..=ny)
        .into_par_iter()
        .map(|j| {
            let (mut sizes, mut out) = (Vec::new(), Vec::new());
            let visited = row_quads(&cols, j, |corners, faces, solid| {
                let start = out.len();
                let mut first_mid = None;
                for c in 0..4 {
                    let [i, j, k] = corners[c];
                    out.push(vertex(i, j, k as u32, faces[c]));
                    // A pinched edge to the next corner gets the midpoint on this face's solid side.
                    let next = corners[(c + 1) % 4];
                    let a = (0..3).find(|&a| next[a] != corners[c][a]).expect("an edge");
                    let lo = if next[a] < corners[c][a] {
                        next
                    } else {
                        corners[c]
                    };
                    let lower_end = &rows[lo[1] as usize];
                    let config = config_at(lower_end, lo[0] as u32, lo[2] as u32);
                    if pinched_edge(config, a).is_some() {
                        let (u, v) = across(a);
                        let q = (solid[u] - (lo[u] - 1)) as usize
                            + 2 * (solid[v] - (lo[v] - 1)) as usize;
                        first_mid.get_or_insert(out.len());
                        out.push(midpoint(lo[0], lo[1], lo[2], a, q));
                    }
                }
                // Start a polygon with a midpoint at its first midpoint: readers and the STL/GLB
                // writers fan polygons from their first corner, and a fan from a lattice corner would
                // add the pinched edge itself as a diagonal, shared with the other face of its wedge.
                if let Some(m) = first_mid {
                    out[start..].rotate_left(m - start);
                }
                sizes.push((out.len() - start) as u32);
            });
            debug_assert_eq!(
                visited, quads_per_row[j as usize],
                "the popcounts count the faces"
            );
            (sizes, out)
        })
        .collect();
    let total: usize = polygons.iter().map(|(_, o)| o.len()).sum();
    let mut face_ptr = Vec::with_capacity(quads as usize + 1);
    let mut indices = Vec::with_capacity(total);
    face_ptr.push(0u32);
    for (sizes, out) in polygons {
        for n in sizes {
            face_ptr.push(face_ptr.last().copied().unwrap_or(0) + n);
        }
        indices.extend_from_slice(&out);
    }
    Ok(Mesh {
        positions,
        face_ptr,
        indices,
    })
}

/// The configuration of boundary lattice point (i, ·, k) of `row`.
fn config_at(row: &Row, i: u32, k: u32) -> u8 {
    row.configs[row.entry(i, k)]
}

impl Row {
    /// The entry of boundary lattice point (i, ·, k): a binary search in its lattice column. Every corner
    /// of a boundary face, and every end of a boundary edge, is such a point.
    fn entry(&self, i: u32, k: u32) -> usize {
        let (lo, hi) = (
            self.starts[i as usize] as usize,
            self.starts[i as usize + 1] as usize,
        );
        lo + self.heights[lo..hi]
            .binary_search(&k)
            .expect("a corner of a boundary face is a boundary lattice point")
    }
}

/// Visits the boundary quads owned by lattice row j (z-faces and x-faces of voxel row j, y-faces at
/// y = j), in a fixed order, each with its corners (lattice points, outward order) and, per corner, its
/// face number in that corner's block; returns how many there were.
fn row_quads(
    cols: &Columns,
    j: i64,
    mut visit: impl FnMut([[i64; 3]; 4], [usize; 4], [i64; 3]),
) -> u64 {
    let [nx, ny, nz] = cols.dims.map(|d| d as i64);
    let mut count = 0u64;
    for i in 0..=nx {
        // z-faces of voxel column (i, j) at lattice heights 0..=Z.
        if i < nx && j < ny {
            let here = cols.col(i, j);
            for w in 0..cols.lattice_words() {
                let d = at(here, w) ^ below(here, w);
                bits(d, w, &mut |k| {
                    count += 1;
                    let lower_solid = cols.solid(i, j, k - 1);
                    let corner = |ci: i64, cj: i64| {
                        let b = (1 - ci) as usize + 2 * (1 - cj) as usize;
                        ([i + ci, j + cj, k], face_index(2, b))
                    };
                    let order = if lower_solid {
                        [(0, 0), (1, 0), (1, 1), (0, 1)]
                    } else {
                        [(0, 0), (0, 1), (1, 1), (1, 0)]
                    };
                    let c = order.map(|(a, b)| corner(a, b));
                    let solid = [i, j, if lower_solid { k - 1 } else { k }];
                    visit(c.map(|x| x.0), c.map(|x| x.1), solid);
                });
            }
        }
        // x-faces at x = i between voxel columns (i − 1, j) and (i, j).
        if j < ny {
            let (left, here) = (cols.col(i - 1, j), cols.col(i, j));
            for w in 0..cols.words {
                let d = left[w] ^ here[w];
                bits(d, w, &mut |k| {
                    if k >= nz {
                        return;
                    }
                    count += 1;
                    let left_solid = cols.solid(i - 1, j, k);
                    let corner = |cj: i64, ck: i64| {
                        let b = 2 * (1 - cj) as usize + 4 * (1 - ck) as usize;
                        ([i, j + cj, k + ck], face_index(0, b))
                    };
                    let order = if left_solid {
                        [(0, 0), (1, 0), (1, 1), (0, 1)]
                    } else {
                        [(0, 0), (0, 1), (1, 1), (1, 0)]
                    };
                    let c = order.map(|(a, b)| corner(a, b));
                    let solid = [if left_solid { i - 1 } else { i }, j, k];
                    visit(c.map(|x| x.0), c.map(|x| x.1), solid);
                });
            }
        }
        // y-faces at y = j between voxel columns (i, j − 1) and (i, j).
        if i < nx {
            let (front, here) = (cols.col(i, j - 1), cols.col(i, j));
            for w in 0..cols.words {
                let d = front[w] ^ here[w];
                bits(d, w, &mut |k| {
                    if k >= nz {
                        return;
                    }
                    count += 1;
                    let lower_solid = cols.solid(i, j - 1, k);
                    let corner = |ci: i64, ck: i64| {
                        let b = (1 - ci) as usize + 4 * (1 - ck) as usize;
                        ([i + ci, j, k + ck], face_index(1, b))
                    };
                    // Outward +y is counter-clockwise in the (z, x) plane.
                    let order = if lower_solid {
                        [(0, 0), (0, 1), (1, 1), (1, 0)]
                    } else {
                        [(0, 0), (1, 0), (1, 1), (0, 1)]
                    };
                    let c = order.map(|(a, b)| corner(a, b));
                    let solid = [i, if lower_solid { j - 1 } else { j }, k];
                    visit(c.map(|x| x.0), c.map(|x| x.1), solid);
                });
            }
        }
    }
    count
}

/// Calls `f` with the height of every set bit of word `w`, lowest first.
fn bits(mut d: u32, w: usize, f: &mut dyn FnMut(i64)) {
    while d != 0 {
        let k = (w * 32) as i64 + d.trailing_zeros() as i64;
        d &= d - 1;
        f(k);
    }
}

/// The boundary lattice points of lattice row j, found by whole words: point (i, j, k) is on the boundary
/// when its 8 voxels (layers k − 1 and k of the four voxel columns around lattice column (i, j)) differ.
fn boundary_points(cols: &Columns, j: i64) -> Row {
    let nx = cols.dims[0] as i64;
    let sheets = table();
    let mut row = Row::default();
    for i in 0..=nx {
        row.starts.push(row.heights.len() as u32);
        let around = [
            cols.col(i - 1, j - 1),
            cols.col(i, j - 1),
            cols.col(i - 1, j),
            cols.col(i, j),
        ];
        for w in 0..cols.lattice_words() {
            let (mut and_now, mut or_now, mut and_below, mut or_below) = (!0u32, 0u32, !0u32, 0u32);
            for c in around {
                let (now, under) = (at(c, w), below(c, w));
                and_now &= now;
                or_now |= now;
                and_below &= under;
                or_below |= under;
            }
            let mut mixed = (and_now ^ or_now) | (and_below ^ or_below) | (and_now ^ and_below);
            while mixed != 0 {
                let k = (w * 32) as u32 + mixed.trailing_zeros();
                mixed &= mixed - 1;
                if k > cols.dims[2] {
                    break;
                }
                let config = cols.config(i, j, k as i64);
                row.heights.push(k);
                row.configs.push(config);
                row.first_vertex.push(row.vertices);
                row.vertices += sheets[config as usize].count as u32;
                for a in 0..3 {
                    if pinched_edge(config, a).is_some() {
                        row.pinched.push(edge_key(i as u32, k, a));
                        row.pinched_vertex.push(row.vertices);
                        row.vertices += 2;
                    }
                }
            }
        }
    }
    row.starts.push(row.heights.len() as u32);
    row
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_configuration_splits_into_cycles_with_distinct_offsets() {
        let t = table();
        assert_eq!(t[0].count, 0);
        assert_eq!(t[255].count, 0);
        for (c, s) in t.iter().enumerate() {
            assert!(s.count <= 4, "configuration {c:08b}: {} sheets", s.count);
            for x in 0..s.count as usize {
                for y in x + 1..s.count as usize {
                    assert_ne!(s.offset[x], s.offset[y], "configuration {c:08b}");
                }
            }
        }
        // Two voxels sharing an edge only: two sheets; a lone voxel: one.
        assert_eq!(t[0b0000_1001].count, 2);
        assert_eq!(t[0b0000_0001].count, 1);
        // Two empty voxels at opposite corners of a solid block: two sheets.
        assert_eq!(t[0b0111_1110].count, 2);
        // A tetrahedral checkerboard: four lone corners.
        assert_eq!(t[0b1001_0110].count, 4);
    }
}
