//! The CPU reference voxelizer: a column scanline with the GPU's sampling, the test oracle and the
//! same-machine speed baseline (`--method cpu`).
//!
//! Sampling, shared with the raster path (`glsl/peel.*`, `glsl/voxel_fill.comp`):
//! - Positions go to grid units per axis ((x − origin) / voxel size), so anisotropic voxels are unit cubes
//!   there. Columns are voxel-centre lines along the peel axis `d`; a column (iu, iv) sits at (iu+½, iv+½) of
//!   the (u, v) plane, which is also the pixel centre of the `dims[u]`×`dims[v]` peel framebuffer.
//! - Vertices are snapped to 1/256 grid unit (lavapipe's 8 sub-pixel bits) and coverage is decided exactly in
//!   integers with the top-left rule, so ties on shared edges go to exactly one triangle.
//! - A crossing at depth z (grid units) starts at voxel k = ceil(z − ½): the first centre behind it. z is the
//!   unsnapped triangle's plane at the column where the column lies in its exact projection; where only the
//!   snapped triangle covers the column (within the snapping of an edge), z is that of the exact triangle's
//!   nearest point (`crossing_depth`), never its plane extrapolated, which moves without bound on a steep
//!   sliver (two steep triangles folded over a column put crossings round a voxel centre far from both).
//!   With this, a centre whose count the snapping changes lies within the snapping of a triangle, where the
//!   generalized winding number's near zone decides it exactly. The raster path interpolates the plane over
//!   the covered pixel, which is the extrapolation: in that band round steep triangles' edges a device
//!   method's solid pass can still miscount a centre far from them (the gwn labels k ≠ 0 read this count,
//!   not the device's; a label 0 keeps the device's bit).
//! - Facing: +1 where the triangle's normal points against +d (entering an outward-oriented solid), −1
//!   otherwise. The winding rule fills where the running sum is non-zero, parity where the crossing count is
//!   odd; nothing is filled after a column's last crossing (open meshes never leak to the grid's edge).
//!   Crossings in front of or behind the grid count too (k clamps to 0 or `dims[d]`): with `--bbox` the parts
//!   of the mesh outside the box still decide what is inside.
use super::grid::{Axis, GridFrame, VoxelGrid};
use super::mesh::TriMesh;
use rayon::prelude::*;

/// How crossings make a voxel solid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum FillRule {
    /// Signed winding count, non-zero inside (overlapping and self-intersecting solids come out right).
    Winding,
    /// Harada & Koshizuka's entry/exit pairing (odd crossing count inside): kept for comparison.
    Parity,
    /// The generalized winding number: inside iff |w| ≥ ½ at the voxel centre, exact on any triangle soup
    /// (`voxel::gwn`: the winding rule of the mesh welded and closed by caps, and the fractional term where
    /// it matters). An inverted closed part is solid; on a closed mesh it is the winding rule, bit for bit.
    Gwn,
    /// The generalized winding number with libigl's sign convention: inside iff w ≥ ½ (an inverted closed
    /// part is empty); on a closed mesh it is the positive rule, bit for bit.
    GwnPositive,
    /// Positive winding count inside (w > 0: inward-oriented solids are empty).
    Positive,
}

impl FillRule {
    /// The rule the solid pass rasterizes for this one: the generalized winding numbers start from the
    /// winding (or positive) rule of the closed proxy.
    pub fn solid_pass(self) -> FillRule {
        match self {
            FillRule::Gwn => FillRule::Winding,
            FillRule::GwnPositive => FillRule::Positive,
            r => r,
        }
    }

    /// The rule's name as the command line spells it (`gwn-positive`, …).
    pub fn name(self) -> &'static str {
        match self {
            FillRule::Winding => "winding",
            FillRule::Parity => "parity",
            FillRule::Gwn => "gwn",
            FillRule::GwnPositive => "gwn-positive",
            FillRule::Positive => "positive",
        }
    }

    /// Whether this is one of the generalized winding number's rules.
    pub fn is_gwn(self) -> bool {
        matches!(self, FillRule::Gwn | FillRule::GwnPositive)
    }
}

/// Sub-pixel snapping of the rasterizer: 2^8 steps per grid unit.
pub const SUBPIXEL: f64 = 256.0;

/// A triangle projected for one peel axis, in grid units.
struct Projected {
    /// Snapped (u, v) in 1/256 units.
    q: [[i64; 2]; 3],
    /// Unsnapped (u, v, d) for the depth plane.
    p: [[f64; 3]; 3],
    sign: i8,
}

fn project(mesh: &TriMesh, frame: &GridFrame, axis: Axis, t: [u32; 3]) -> Option<Projected> {
    let (ua, va) = axis.uv();
    let da = axis.index();
    let inv = frame.voxel_size.map(|h| 1.0 / h);
    let mut p = [[0.0f64; 3]; 3];
    let mut q = [[0i64; 2]; 3];
    for c in 0..3 {
        let x = mesh.positions[t[c] as usize];
        let g = |a: usize| (x[a] as f64 - frame.origin[a]) * inv[a];
        p[c] = [g(ua), g(va), g(da)];
        q[c] = [
            (p[c][0] * SUBPIXEL).round() as i64,
            (p[c][1] * SUBPIXEL).round() as i64,
        ];
    }
    let area2 =
        (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]);
    if area2 == 0 {
        return None;
    }
    // The facing comes from the unsnapped 3D orientation (as gl_FrontFacing would, up to a global sign that
    // the non-zero rule ignores); for a triangle flipped by snapping the sign stays that of its plane.
    let n_d = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
    let sign = if n_d < 0.0 { 1 } else { -1 };
    Some(Projected { q, p, sign })
}

/// Whether the edge a→b, in a triangle oriented so edge functions are positive inside, owns centres lying
/// exactly on it (top-left rule in y-down framebuffer coordinates).
fn top_left(a: [i64; 2], b: [i64; 2]) -> bool {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    (dy == 0 && dx > 0) || dy < 0
}

/// The crossings of `tri` with the columns of row `iv`, pushed as (depth in grid units, facing) into
/// `columns[iu]` (`width` columns in a row).
fn rasterize_row(tri: &Projected, iv: i64, width: i64, columns: &mut [Vec<(f64, i8)>]) {
    let mut q = tri.q;
    let mut p = tri.p;
    let area2 =
        (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]);
    if area2 < 0 {
        q.swap(1, 2);
        p.swap(1, 2);
    }
    let cy = iv * 256 + 128;
    let umin = q.iter().map(|v| v[0]).min().unwrap();
    let umax = q.iter().map(|v| v[0]).max().unwrap();
    // Columns whose centres (iu·256 + 128) lie in [umin, umax].
    let i0 = ((umin - 128) as f64 / 256.0).ceil().max(0.0) as i64;
    let i1 = (((umax - 128) as f64 / 256.0).floor() as i64).min(width - 1);
    // Depth plane d = d0 + a·(u − u0) + b·(v − v0) from the unsnapped vertices.
    let (e1, e2) = (
        [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]],
        [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]],
    );
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    for iu in i0..=i1 {
        let c = [iu * 256 + 128, cy];
        let mut inside = true;
        for k in 0..3 {
            let (a, b) = (q[k], q[(k + 1) % 3]);
            let e = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if e < 0 || (e == 0 && !top_left(a, b)) {
                inside = false;
                break;
            }
        }
        if !inside {
            continue;
        }
        let (u, v) = (iu as f64 + 0.5, iv as f64 + 0.5);
        columns[iu as usize].push((crossing_depth(&p, e1, e2, det, u, v), tri.sign));
    }
}

/// The depth where the column through (u, v) crosses the unsnapped triangle `p` (voxel units): its plane
/// there when (u, v) lies in the triangle's projection, else the depth at the projection's nearest point,
/// on an edge. The snapped triangle can cover a column the exact one misses by up to the snapping; the
/// plane extrapolated there moves by that distance over the triangle's slope, without bound on a steep
/// sliver (a pair of steep triangles folded over a column gave crossings 0.6 voxel apart round a voxel
/// centre outside the near zone, and the count there one too many). A point of the triangle itself keeps
/// every miscounted centre within the snapping of a triangle: in the near zone (`voxel::gwn::zone`).
fn crossing_depth(p: &[[f64; 3]; 3], e1: [f64; 3], e2: [f64; 3], det: f64, u: f64, v: f64) -> f64 {
    if det.abs() > 0.0 {
        let (du, dv) = (u - p[0][0], v - p[0][1]);
        let s = (du * e2[1] - dv * e2[0]) / det;
        let t = (e1[0] * dv - e1[1] * du) / det;
        if s >= 0.0 && t >= 0.0 && s + t <= 1.0 {
            return p[0][2] + s * e1[2] + t * e2[2];
        }
    }
    let mut best = (f64::INFINITY, (p[0][2] + p[1][2] + p[2][2]) / 3.0);
    for k in 0..3 {
        let (a, b) = (p[k], p[(k + 1) % 3]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let length2 = ex * ex + ey * ey;
        let lambda = if length2 > 0.0 {
            (((u - a[0]) * ex + (v - a[1]) * ey) / length2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (x, y) = (a[0] + lambda * ex - u, a[1] + lambda * ey - v);
        let d2 = x * x + y * y;
        if d2 < best.0 {
            best = (d2, a[2] + lambda * (b[2] - a[2]));
        }
    }
    best.1
}

/// Sets bits `[k0, k1)` of one column.
pub fn set_bit_range(column: &mut [u32], k0: u32, k1: u32) {
    let mut k = k0;
    while k < k1 {
        let w = (k / 32) as usize;
        let b = k % 32;
        let n = (32 - b).min(k1 - k);
        let mask = if n == 32 {
            u32::MAX
        } else {
            ((1u32 << n) - 1) << b
        };
        column[w] |= mask;
        k += n;
    }
}

/// Fills one column of `depth` voxels from its crossings (sorted front to back in place).
pub fn fill_column(crossings: &mut [(f64, i8)], depth: u32, rule: FillRule, column: &mut [u32]) {
    crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut winding: i32 = 0;
    let mut k_prev = 0u32;
    for (n, &(z, s)) in crossings.iter().enumerate() {
        let k = ((z - 0.5).ceil().max(0.0).min(depth as f64)) as u32;
        let inside = match rule {
            FillRule::Winding | FillRule::Gwn => winding != 0,
            FillRule::Positive | FillRule::GwnPositive => winding > 0,
            FillRule::Parity => n % 2 == 1,
        };
        if inside && k > k_prev {
            set_bit_range(column, k_prev, k);
        }
        winding += s as i32;
        k_prev = k;
    }
}

/// Voxelizes `mesh` in `frame` with columns along `axis` (CPU, all cores).
///
/// ```
/// use gregvox::voxel::{cpu::{voxelize_cpu, FillRule}, grid::{Axis, GridFrame}, mesh::TriMesh};
/// let cube = TriMesh::cube([0.0; 3], 1.0);
/// let frame = GridFrame::from_points(&cube.positions, 8).unwrap();
/// let grid = voxelize_cpu(&cube, &frame, Axis::Z, FillRule::Winding);
/// assert_eq!(grid.count(), 512);
/// ```
pub fn voxelize_cpu(mesh: &TriMesh, frame: &GridFrame, axis: Axis, rule: FillRule) -> VoxelGrid {
    let ua = axis.uv().0;
    let (width, depth) = (frame.dims[ua], frame.dims[axis.index()]);
    let (projected, rows) = projected_rows(mesh, frame, axis);
    let mut grid = VoxelGrid::empty(*frame, axis);
    let w = frame.words_per_column(axis) as usize;
    let row_words = w * width as usize;
    grid.words
        .par_chunks_mut(row_words)
        .zip(rows.par_iter())
        .enumerate()
        .for_each(|(iv, (out, tris))| {
            let mut columns: Vec<Vec<(f64, i8)>> = vec![Vec::new(); width as usize];
            for &t in tris {
                rasterize_row(
                    &projected[t as usize],
                    iv as i64,
                    width as i64,
                    &mut columns,
                );
            }
            for (iu, col) in columns.iter_mut().enumerate() {
                if !col.is_empty() {
                    fill_column(col, depth, rule, &mut out[iu * w..(iu + 1) * w]);
                }
            }
        });
    grid
}

/// Rasterizes only the rows `wanted` holds (row index → what the caller keeps for it) along `axis`, all
/// cores: `per_row` gets a row's items and the crossings of every column of the row; its answers come back
/// flattened.
fn over_rows<W: Send, R: Send>(
    mesh: &TriMesh,
    frame: &GridFrame,
    axis: Axis,
    wanted: std::collections::BTreeMap<u32, W>,
    per_row: impl Fn(W, &mut [Vec<(f64, i8)>]) -> Vec<R> + Sync,
) -> Vec<R> {
    let ua = axis.uv().0;
    let width = frame.dims[ua];
    let (projected, rows) = projected_rows(mesh, frame, axis);
    wanted
        .into_par_iter()
        .flat_map_iter(|(iv, items)| {
            let mut columns: Vec<Vec<(f64, i8)>> = vec![Vec::new(); width as usize];
            for &t in &rows[iv as usize] {
                rasterize_row(
                    &projected[t as usize],
                    iv as i64,
                    width as i64,
                    &mut columns,
                );
            }
            per_row(items, &mut columns)
        })
        .collect()
}

/// Recomputes the columns `lost` (linear indices v·width + u of `grid`'s bit axis, any order) of a grid
/// voxelized from `mesh` with `rule`, exactly as [`voxelize_cpu`] fills them: depth peeling's repair of the
/// columns where it lost an equal-depth fragment (`passes::peel_check`). Only the rows holding a lost column
/// are rasterized: O(triangles + lost rows' crossings).
pub fn refill_columns(mesh: &TriMesh, grid: &mut VoxelGrid, rule: FillRule, lost: &[u32]) {
    if lost.is_empty() {
        return;
    }
    let (frame, axis) = (grid.frame, grid.bit_axis);
    let (ua, va) = axis.uv();
    let (width, height, depth) = (frame.dims[ua], frame.dims[va], frame.dims[axis.index()]);
    let mut by_row: std::collections::BTreeMap<u32, Vec<(u32, u32)>> = Default::default();
    for &c in lost {
        if c < width * height {
            by_row
                .entry(c / width)
                .or_default()
                .push((c / width, c % width));
        }
    }
    let w = frame.words_per_column(axis) as usize;
    // (first word of the column, its words) for every lost column.
    let refilled = over_rows(mesh, &frame, axis, by_row, |cols, columns| {
        cols.into_iter()
            .map(|(iv, iu)| {
                let mut bits = vec![0u32; w];
                fill_column(&mut columns[iu as usize], depth, rule, &mut bits);
                ((iv as usize * width as usize + iu as usize) * w, bits)
            })
            .collect()
    });
    for (at, bits) in refilled {
        grid.words[at..at + w].copy_from_slice(&bits);
    }
}

/// The winding number of `mesh` at the centres of `voxels`, as [`voxelize_cpu`] along `axis` counts it: the
/// facings of the crossings of each voxel's column that start at or before the voxel (0 past the column's
/// last crossing, where nothing is filled). Integer and exact for a closed mesh away from its triangles; the
/// generalized winding number's crossing voxels read it (`voxel::gwn`). Only the rows that hold a voxel
/// are rasterized.
pub fn column_windings(
    mesh: &TriMesh,
    frame: &GridFrame,
    axis: Axis,
    voxels: &[[u32; 3]],
) -> Vec<i32> {
    let (ua, va, da) = {
        let (u, v) = axis.uv();
        (u, v, axis.index())
    };
    let depth = frame.dims[da];
    let mut by_row: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
    for (n, v) in voxels.iter().enumerate() {
        by_row.entry(v[va]).or_default().push(n);
    }
    let answers = over_rows(mesh, frame, axis, by_row, |members, columns| {
        members
            .into_iter()
            .map(|n| {
                let v = voxels[n];
                let starts = columns[v[ua] as usize]
                    .iter()
                    .map(|&(z, s)| (((z - 0.5).ceil().max(0.0).min(depth as f64)) as u32, s));
                let (mut winding, mut later) = (0i32, false);
                for (k, s) in starts {
                    if k <= v[da] {
                        winding += s as i32;
                    } else {
                        later = true;
                    }
                }
                (n, if later { winding } else { 0 })
            })
            .collect()
    });
    let mut out = vec![0; voxels.len()];
    for (n, w) in answers {
        out[n] = w;
    }
    out
}

/// A box of voxels `[lo, hi)` (grid indices) whose crossing counts decide it against its label `k`.
pub type Region = ([u32; 3], [u32; 3], i32);

/// Sets every voxel of `regions` from the winding number n of `mesh` at its centre, counted as
/// [`voxelize_cpu`] counts it along the grid's bit axis ([`column_windings`]' count): solid iff n ≠ k, or
/// n > k when `positive` (the generalized winding number's decision where the fractional term lies
/// strictly between k − ½ and k + ½). Only the rows the regions touch are rasterized, each once. Returns how
/// many voxels changed.
pub fn relabel(mesh: &TriMesh, grid: &mut VoxelGrid, regions: &[Region], positive: bool) -> u64 {
    if regions.is_empty() {
        return 0;
    }
    let axis = grid.bit_axis;
    let frame = grid.frame;
    let (ua, va, da) = {
        let (u, v) = axis.uv();
        (u, v, axis.index())
    };
    let (width, depth) = (frame.dims[ua], frame.dims[da]);
    // Per row: (u0, u1, d0, d1, k).
    let mut by_row: std::collections::BTreeMap<u32, Vec<[i64; 5]>> = Default::default();
    for &(lo, hi, k) in regions {
        for v in lo[va]..hi[va] {
            by_row.entry(v).or_default().push([
                lo[ua] as i64,
                hi[ua] as i64,
                lo[da] as i64,
                hi[da] as i64,
                k as i64,
            ]);
        }
    }
    let (projected, rows) = projected_rows(mesh, &frame, axis);
    let rows_wanted: Vec<(u32, Vec<[i64; 5]>)> = by_row.into_iter().collect();
    let changes: Vec<Vec<(u32, u32, u32, bool)>> = rows_wanted
        .par_iter()
        .map(|(iv, spans)| {
            let mut columns: Vec<Vec<(f64, i8)>> = vec![Vec::new(); width as usize];
            for &t in &rows[*iv as usize] {
                rasterize_row(
                    &projected[t as usize],
                    *iv as i64,
                    width as i64,
                    &mut columns,
                );
            }
            // Crossings as (first voxel at or after, facing), sorted, per column on first use.
            let mut sorted: Vec<Option<Vec<(u32, i8)>>> = vec![None; width as usize];
            let mut out = Vec::new();
            for &[u0, u1, d0, d1, k] in spans {
                for u in u0 as usize..u1 as usize {
                    let starts = sorted[u].get_or_insert_with(|| {
                        let mut s: Vec<(u32, i8)> = columns[u]
                            .iter()
                            .map(|&(z, s)| {
                                (((z - 0.5).ceil().max(0.0).min(depth as f64)) as u32, s)
                            })
                            .collect();
                        s.sort_unstable();
                        s
                    });
                    let (mut next, mut n) = (0usize, 0i64);
                    for d in d0 as u32..d1 as u32 {
                        while next < starts.len() && starts[next].0 <= d {
                            n += starts[next].1 as i64;
                            next += 1;
                        }
                        // Nothing is filled after the column's last crossing.
                        let n = if next < starts.len() { n } else { 0 };
                        let solid = if positive { n > k } else { n != k };
                        out.push((u as u32, *iv, d, solid));
                    }
                }
            }
            out
        })
        .collect();
    let mut flipped = 0;
    for (u, v, d, solid) in changes.into_iter().flatten() {
        let mut ijk = [0u32; 3];
        ijk[ua] = u;
        ijk[va] = v;
        ijk[da] = d;
        if grid.get(ijk[0], ijk[1], ijk[2]) != solid {
            grid.set(ijk[0], ijk[1], ijk[2], solid);
            flipped += 1;
        }
    }
    flipped
}

/// The triangles of `mesh` projected for `axis` (those with a non-zero snapped area), bucketed by row.
fn projected_rows(
    mesh: &TriMesh,
    frame: &GridFrame,
    axis: Axis,
) -> (Vec<Projected>, Vec<Vec<u32>>) {
    let projected: Vec<Projected> = mesh
        .triangles
        .par_iter()
        .filter_map(|&t| project(mesh, frame, axis, t))
        .collect();
    let rows = bucket_rows(&projected, frame.dims[axis.uv().1]);
    (projected, rows)
}

/// Triangles bucketed by the rows (of `height`) their snapped bounding box touches.
fn bucket_rows(projected: &[Projected], height: u32) -> Vec<Vec<u32>> {
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); height as usize];
    for (i, t) in projected.iter().enumerate() {
        let vmin = t.q.iter().map(|v| v[1]).min().unwrap();
        let vmax = t.q.iter().map(|v| v[1]).max().unwrap();
        let r0 = ((vmin - 128) as f64 / 256.0).ceil().max(0.0) as i64;
        let r1 = (((vmax - 128) as f64 / 256.0).floor() as i64).min(height as i64 - 1);
        for r in r0..=r1 {
            rows[r as usize].push(i as u32);
        }
    }
    rows
}

/// Number of crossings in the deepest column along `axis`: the layers depth peeling needs.
pub fn max_depth_complexity(mesh: &TriMesh, frame: &GridFrame, axis: Axis) -> u32 {
    let ua = axis.uv().0;
    let width = frame.dims[ua];
    let (projected, rows) = projected_rows(mesh, frame, axis);
    let mut deepest = 0;
    let mut columns: Vec<Vec<(f64, i8)>> = vec![Vec::new(); width as usize];
    for (iv, tris) in rows.iter().enumerate() {
        for &t in tris {
            rasterize_row(
                &projected[t as usize],
                iv as i64,
                width as i64,
                &mut columns,
            );
        }
        for c in columns.iter_mut() {
            deepest = deepest.max(c.len() as u32);
            c.clear();
        }
    }
    deepest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxel::gwn::kernel::{triangle_distance, winding_number};

    #[test]
    fn a_column_beside_a_steep_sliver_crosses_it_at_a_point_of_the_triangle() {
        // Near vertical: projected, a sliver 1e-3 voxel wide along u, spanning depths −8 … 8.
        let p = [[0.0, 0.5, 0.0], [4.0, 0.5005, 8.0], [4.0, 0.4995, -8.0]];
        let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
        let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
        let det = e1[0] * e2[1] - e1[1] * e2[0];
        // Inside the projection: the plane.
        let z = crossing_depth(&p, e1, e2, det, 2.0, 0.5);
        assert!((z - 0.0).abs() < 1e-9, "{z}");
        // 0.01 voxel beside it the plane would lie 40 voxels away; the crossing stays on the triangle.
        let (du, dv) = (2.0 - p[0][0], 0.51 - p[0][1]);
        let (s, t) = (
            (du * e2[1] - dv * e2[0]) / det,
            (e1[0] * dv - e1[1] * du) / det,
        );
        assert!((p[0][2] + s * e1[2] + t * e2[2]).abs() > 30.0);
        let z = crossing_depth(&p, e1, e2, det, 2.0, 0.51);
        assert!((-8.0..=8.0).contains(&z), "{z}");
        // A degenerate projection (a vertical triangle) takes its nearest edge point too.
        let q = [[0.0, 0.5, 0.0], [4.0, 0.5, 8.0], [2.0, 0.5, -8.0]];
        let z = crossing_depth(&q, [4.0, 0.0, 8.0], [2.0, 0.0, -8.0], 0.0, 4.0, 0.5);
        assert!((z - 8.0).abs() < 1e-9, "{z}");
    }

    /// Closed, thin, nearly vertical tetrahedra (faces that project to slivers), seeded.
    fn steep_slivers(count: usize, seed: u64) -> TriMesh {
        let mut rng = crate::geom::random::SplitMix64(seed);
        let mut next = move || rng.unit();
        let mut mesh = TriMesh::default();
        for _ in 0..count {
            let c = [next() * 8.0, next() * 8.0, next() * 8.0];
            let angle = next() * std::f64::consts::TAU;
            let (cs, sn) = (angle.cos(), angle.sin());
            let base = mesh.positions.len() as u32;
            for _ in 0..4 {
                // Long along a horizontal direction and z, 1e-3 thin across.
                let (a, b, h) = (
                    next() * 3.0 - 1.5,
                    (next() - 0.5) * 2e-3,
                    next() * 4.0 - 2.0,
                );
                let p = [c[0] + a * cs - b * sn, c[1] + a * sn + b * cs, c[2] + h];
                mesh.positions.push(p.map(|x| x as f32));
            }
            let [a, b, c, d] = [base, base + 1, base + 2, base + 3];
            let tets = [[a, b, c], [a, c, d], [a, d, b], [b, d, c]];
            // Oriented outward (the sign of the volume).
            use crate::voxel::surface::{cross, dot, sub};
            let v = |i: u32| mesh.positions[i as usize].map(|x| x as f64);
            let vol = dot(sub(v(b), v(a)), cross(sub(v(c), v(a)), sub(v(d), v(a))));
            for mut t in tets {
                if vol > 0.0 {
                    t.swap(1, 2);
                }
                mesh.triangles.push(t);
            }
        }
        mesh
    }

    #[test]
    fn column_counts_are_the_exact_winding_number_away_from_steep_slivers() {
        let mut checked = 0u64;
        for seed in 0..6u64 {
            let mesh = steep_slivers(40, seed);
            let frame = GridFrame::from_points(&mesh.positions, 24).unwrap();
            let dims = frame.dims;
            let voxels: Vec<[u32; 3]> = (0..dims[2])
                .flat_map(|k| (0..dims[1]).flat_map(move |j| (0..dims[0]).map(move |i| [i, j, k])))
                .collect();
            let counts = column_windings(&mesh, &frame, Axis::Z, &voxels);
            let near = frame.voxel_size.iter().fold(0.0f64, |m, &h| m.max(h)) / 64.0;
            let tris: Vec<[[f64; 3]; 3]> = mesh
                .triangles
                .iter()
                .map(|t| t.map(|v| mesh.positions[v as usize].map(|x| x as f64)))
                .collect();
            for (v, &n) in voxels.iter().zip(&counts) {
                let p = frame.centre(v[0], v[1], v[2]);
                if tris
                    .iter()
                    .any(|t| triangle_distance(p, t[0], t[1], t[2]) <= near)
                {
                    continue;
                }
                let w = winding_number(&mesh, p);
                assert_eq!(n, w.round() as i32, "seed {seed} voxel {v:?}: w = {w}");
                checked += 1;
            }
        }
        assert!(checked > 50_000, "{checked}");
    }
}
