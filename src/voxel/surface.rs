//! Surface voxels: every voxel whose closed box a triangle touches, by Akenine-Möller's triangle–box
//! separating-axis test ("Fast 3D triangle-box overlap testing", 2001: the 3 box normals, the triangle's
//! normal and the 9 edge × axis cross products), and the `--fill` modes that combine them with the solid.
//!
//! Invariants:
//! - The test runs in grid units per axis ((x − origin) / voxel size), where voxel (i,j,k) is the closed unit
//!   box [i, i+1]×[j, j+1]×[k, k+1]: an axis-aligned affine map keeps overlap, so anisotropic voxels need
//!   nothing special. Arithmetic is f64 on the unsnapped f32 positions; touching (a separation of exactly
//!   zero) counts as overlap.
//! - Only voxels that can touch are tested: per triangle, per column (i, j) of its box, the k range the
//!   triangle's plane spans over the column (widened by one voxel each way); so a huge triangle costs its
//!   area in voxels, not its box's volume.
//! - Triangles wholly outside the grid mark nothing; the result has bit axis z.
use super::grid::{Axis, GridFrame, VoxelGrid};
use super::mesh::TriMesh;
use rayon::prelude::*;

/// Which voxels a voxelization marks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Fill {
    /// Voxels whose centre is inside the solid.
    #[default]
    Solid,
    /// Voxels whose box a triangle touches (a shell; open surfaces and sheets included).
    Surface,
    /// Both: walls thinner than a voxel survive (binvox `-aw`).
    Both,
}

impl Fill {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Fill::Solid => "solid",
            Fill::Surface => "surface",
            Fill::Both => "both",
        }
    }
}

// f64 vector helpers in the operation order the GPU shaders mirror (glsl/voxel_surface.comp,
// glsl/include/gwn.glsl): shared with `voxel::gwn`.
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Whether triangle `t` touches the closed box of centre `c` and half-size `h` on every axis (the 13 axes of
/// the separating-axis theorem; an axis with a zero vector separates nothing and is skipped).
///
/// ```
/// use gregvox::voxel::surface::triangle_box_overlap;
/// let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
/// assert!(triangle_box_overlap([0.5, 0.5, 0.5], 0.5, t)); // the triangle lies on the box's face: touching
/// assert!(!triangle_box_overlap([0.5, 0.5, 1.5], 0.5, t));
/// assert!(!triangle_box_overlap([1.5, 1.5, 0.5], 0.5, t)); // beyond the hypotenuse
/// ```
pub fn triangle_box_overlap(c: [f64; 3], h: f64, t: [[f64; 3]; 3]) -> bool {
    let v = [sub(t[0], c), sub(t[1], c), sub(t[2], c)];
    // 1. The box normals: the triangle's extent against the box's.
    let outside = |a: usize| {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        lo > h || hi < -h
    };
    if (0..3).any(outside) {
        return false;
    }
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    // 2. The nine cross products of the edges with the box axes.
    for edge in &e {
        for a in 0..3 {
            let mut axis = [0.0; 3];
            axis[a] = 1.0;
            let n = cross(*edge, axis);
            if n == [0.0; 3] {
                continue;
            }
            if separates(n, &v, h) {
                return false;
            }
        }
    }
    // 3. The triangle's plane.
    let n = cross(e[0], e[1]);
    n == [0.0; 3] || !separates(n, &v, h)
}

/// Whether axis `n` separates the triangle `v` (relative to the box centre) from the box of half-size `h`.
fn separates(n: [f64; 3], v: &[[f64; 3]; 3], h: f64) -> bool {
    let p = [dot(n, v[0]), dot(n, v[1]), dot(n, v[2])];
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let r = h * (n[0].abs() + n[1].abs() + n[2].abs());
    lo > r || hi < -r
}

/// The voxels of `frame` whose boxes the triangles of `mesh` touch (bit axis z; all cores).
///
/// ```
/// use gregvox::voxel::{grid::GridFrame, mesh::TriMesh, surface::voxelize_surface};
/// let cube = TriMesh::cube([0.0; 3], 1.0);
/// let g = voxelize_surface(&cube, &GridFrame::cubic(4, [0.0; 3], 1.0));
/// assert_eq!(g.count(), 64 - 8); // the shell: every voxel but the 2×2×2 core
/// ```
pub fn voxelize_surface(mesh: &TriMesh, frame: &GridFrame) -> VoxelGrid {
    let inv = frame.voxel_size.map(|s| 1.0 / s);
    let dims = frame.dims;
    let grid_tris: Vec<[[f64; 3]; 3]> = mesh
        .triangles
        .par_iter()
        .map(|t| {
            t.map(|v| {
                let p = mesh.positions[v as usize];
                std::array::from_fn(|a| (p[a] as f64 - frame.origin[a]) * inv[a])
            })
        })
        .collect();
    // Bucket by the rows j (bit axis z: a row of columns (x, y = j) owns X·W consecutive words).
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); dims[1] as usize];
    for (n, t) in grid_tris.iter().enumerate() {
        if let Some((j0, j1)) = touched(t, 1, dims[1]) {
            for j in j0..=j1 {
                rows[j as usize].push(n as u32);
            }
        }
    }
    let mut grid = VoxelGrid::empty(*frame, Axis::Z);
    let w = frame.words_per_column(Axis::Z) as usize;
    grid.words
        .par_chunks_mut(w * dims[0] as usize)
        .zip(rows.par_iter())
        .enumerate()
        .for_each(|(j, (row, tris))| {
            for &n in tris {
                mark_row(&grid_tris[n as usize], j as u32, dims, w, row);
            }
        });
    grid
}

/// The range of voxel indices along `axis` (of `n`) whose closed boxes the triangle's extent touches.
fn touched(t: &[[f64; 3]; 3], axis: usize, n: u32) -> Option<(u32, u32)> {
    let lo = t[0][axis].min(t[1][axis]).min(t[2][axis]);
    let hi = t[0][axis].max(t[1][axis]).max(t[2][axis]);
    // Voxel i touches [lo, hi] iff i ≤ hi and i + 1 ≥ lo.
    let i0 = (lo - 1.0).ceil().max(0.0);
    let i1 = hi.floor().min(n as f64 - 1.0);
    (i0 <= i1).then_some((i0 as u32, i1 as u32))
}

/// Marks the voxels of row `j` (columns (i, j), bits along z) that triangle `t` touches.
fn mark_row(t: &[[f64; 3]; 3], j: u32, dims: [u32; 3], w: usize, row: &mut [u32]) {
    let Some((i0, i1)) = touched(t, 0, dims[0]) else {
        return;
    };
    let Some((k0, k1)) = touched(t, 2, dims[2]) else {
        return;
    };
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    for i in i0..=i1 {
        // The k range of the plane over the column's footprint, widened by one voxel against rounding; the
        // separating-axis test decides each voxel.
        let (mut ka, mut kb) = (k0, k1);
        if n[2].abs() > 1e-12 * (n[0].abs() + n[1].abs()) {
            let z_at =
                |x: f64, y: f64| t[0][2] - (n[0] * (x - t[0][0]) + n[1] * (y - t[0][1])) / n[2];
            let (x, y) = (i as f64, j as f64);
            let zs = [
                z_at(x, y),
                z_at(x + 1.0, y),
                z_at(x, y + 1.0),
                z_at(x + 1.0, y + 1.0),
            ];
            let zlo = zs.iter().copied().fold(f64::INFINITY, f64::min);
            let zhi = zs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let a = (zlo.floor() - 1.0).max(k0 as f64);
            let b = (zhi.floor() + 1.0).min(k1 as f64);
            if a > b {
                continue;
            }
            (ka, kb) = (a as u32, b as u32);
        }
        let col = &mut row[i as usize * w..(i as usize + 1) * w];
        for k in ka..=kb {
            let c = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
            if triangle_box_overlap(c, 0.5, *t) {
                col[(k / 32) as usize] |= 1 << (k % 32);
            }
        }
    }
}
