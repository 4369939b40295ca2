//! Rasterisation kernels of the lecture notes: Bresenham lines and 3D voxel traversal (Amanatides–Woo).
//!
//! Conventions:
//! - [`bresenham`] works on integer (x, y) and returns every pixel from `p0` to `p1`, **both end points
//!   included**, in order. It is exactly `skimage.draw.line(y0, x0, y1, x1)` read as (x = column, y = row):
//!   the major axis is y only when |Δy| > |Δx| (a tie steps along x), and the minor coordinate advances
//!   while the error term is ≥ 0. It depends only on p1 − p0 (translation invariant), but p1→p0 is not
//!   always p0→p1 reversed (rounding ties go the same way in both directions: 112 of the 289 offsets in
//!   [−8, 8]² differ, exactly as in skimage). Allocates max(|Δx|, |Δy|) + 1 points.
//! - [`VoxelGrid`]: voxel (i, j, k) is the box origin + [i, i+1]×[j, j+1]×[k, k+1] · cell. The traversal
//!   visits, in order along the ray, every voxel whose box the ray crosses over a parameter interval of
//!   positive length; where the ray passes exactly through a voxel edge or corner it steps the tied axes
//!   together (the voxels touched only along that edge have a zero-length intersection and are skipped).
use glam::{DVec3, IVec2, IVec3, UVec3};

/// Pixels of the segment p0→p1, both end points included (skimage's convention, see the module docs).
///
/// ```
/// use gregvox::geom::raster::bresenham;
/// use glam::IVec2;
/// // the notes' vector in skimage (row, col): (0,1)→(6,4) is (x, y) = (1,0)→(4,6)
/// let l = bresenham(IVec2::new(1, 0), IVec2::new(4, 6));
/// let rc: Vec<(i32, i32)> = l.iter().map(|p| (p.y, p.x)).collect();
/// assert_eq!(rc, vec![(0, 1), (1, 2), (2, 2), (3, 3), (4, 3), (5, 4), (6, 4)]);
/// ```
pub fn bresenham(p0: IVec2, p1: IVec2) -> Vec<IVec2> {
    // skimage's _line with r = y, c = x
    let (mut r, mut c) = (p0.y as i64, p0.x as i64);
    let (r1, c1) = (p1.y as i64, p1.x as i64);
    let mut dr = (r1 - r).abs();
    let mut dc = (c1 - c).abs();
    let mut sc = if c1 - c > 0 { 1 } else { -1 };
    let mut sr = if r1 - r > 0 { 1 } else { -1 };
    let steep = dr > dc;
    if steep {
        std::mem::swap(&mut c, &mut r);
        std::mem::swap(&mut dc, &mut dr);
        std::mem::swap(&mut sc, &mut sr);
    }
    let mut d = 2 * dr - dc;
    let mut out = Vec::with_capacity(dc as usize + 1);
    for _ in 0..dc {
        out.push(if steep {
            IVec2::new(r as i32, c as i32)
        } else {
            IVec2::new(c as i32, r as i32)
        });
        while d >= 0 {
            r += sr;
            d -= 2 * dc;
        }
        c += sc;
        d += 2 * dr;
    }
    out.push(p1);
    out
}

/// A regular grid of `dims` cubic voxels of side `cell` with its minimum corner at `origin`.
///
/// ```
/// use gregvox::geom::raster::VoxelGrid;
/// use glam::{DVec3, UVec3};
/// let g = VoxelGrid { origin: DVec3::ZERO, cell: 0.25, dims: UVec3::new(4, 4, 2) };
/// assert_eq!(g.voxel_box(glam::IVec3::new(3, 3, 1)).1, DVec3::new(1.0, 1.0, 0.5));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelGrid {
    /// Minimum corner.
    pub origin: DVec3,
    /// Voxel side (> 0).
    pub cell: f64,
    /// Voxel counts along x, y, z.
    pub dims: UVec3,
}

impl VoxelGrid {
    /// A grid; `cell` must be finite and > 0 and the origin finite.
    ///
    /// ```
    /// use gregvox::geom::raster::VoxelGrid;
    /// use glam::{DVec3, UVec3};
    /// assert!(VoxelGrid::new(DVec3::ZERO, 0.5, UVec3::splat(8)).is_ok());
    /// assert!(VoxelGrid::new(DVec3::ZERO, 0.0, UVec3::splat(8)).is_err());
    /// ```
    pub fn new(origin: DVec3, cell: f64, dims: UVec3) -> crate::Result<Self> {
        if !(cell > 0.0 && cell.is_finite() && origin.is_finite()) {
            return Err(crate::Error::Invalid(format!(
                "voxel grid: cell {cell} / origin {origin} not usable"
            )));
        }
        Ok(VoxelGrid { origin, cell, dims })
    }

    /// The box [min, max] of voxel `v`.
    ///
    /// ```
    /// use gregvox::geom::raster::VoxelGrid;
    /// use glam::{DVec3, IVec3, UVec3};
    /// let g = VoxelGrid { origin: DVec3::ONE, cell: 0.5, dims: UVec3::splat(4) };
    /// assert_eq!(g.voxel_box(IVec3::new(1, 0, 0)), (DVec3::new(1.5, 1.0, 1.0), DVec3::new(2.0, 1.5, 1.5)));
    /// ```
    pub fn voxel_box(&self, v: IVec3) -> (DVec3, DVec3) {
        let lo = self.origin + v.as_dvec3() * self.cell;
        (lo, lo + DVec3::splat(self.cell))
    }
}

/// The parameter interval [t0, t1] of `origin + t·dir` inside the box [lo, hi] intersected with
/// [t_min, t_max] (slab test); `None` if empty. An axis with dir = 0 keeps the ray iff origin is within the
/// closed slab.
///
/// ```
/// use gregvox::geom::raster::ray_box;
/// use glam::DVec3;
/// let r = ray_box(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, DVec3::ZERO, DVec3::ONE, 0.0, 10.0);
/// assert_eq!(r, Some((1.0, 2.0)));
/// ```
pub fn ray_box(
    origin: DVec3,
    dir: DVec3,
    lo: DVec3,
    hi: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (t_min, t_max);
    for a in 0..3 {
        if dir[a] == 0.0 {
            if origin[a] < lo[a] || origin[a] > hi[a] {
                return None;
            }
        } else {
            let inv = 1.0 / dir[a];
            let (mut ta, mut tb) = ((lo[a] - origin[a]) * inv, (hi[a] - origin[a]) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Amanatides–Woo traversal of `grid` along `origin + t·dir`, t ∈ [t_min, t_max]: calls
/// `visit(voxel, t_enter, t_exit)` for each voxel in order and stops early when it returns `false` (ray
/// casting stops at the first solid voxel). `dir` need not be unit; a zero or non-finite ray visits nothing.
///
/// ```
/// use gregvox::geom::raster::{dda_traverse, VoxelGrid};
/// use glam::{DVec3, IVec3, UVec3};
/// let g = VoxelGrid { origin: DVec3::ZERO, cell: 1.0, dims: UVec3::splat(4) };
/// let mut hit = None;
/// dda_traverse(&g, DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 0.0, 100.0, |v, t0, _| {
///     if v.x == 2 { hit = Some((v, t0)); false } else { true }
/// });
/// assert_eq!(hit, Some((IVec3::new(2, 0, 0), 3.0)));
/// ```
pub fn dda_traverse(
    grid: &VoxelGrid,
    origin: DVec3,
    dir: DVec3,
    t_min: f64,
    t_max: f64,
    mut visit: impl FnMut(IVec3, f64, f64) -> bool,
) {
    if !(origin.is_finite() && dir.is_finite() && dir != DVec3::ZERO)
        || grid.dims.min_element() == 0
    {
        return;
    }
    let lo = grid.origin;
    let hi = grid.origin + grid.dims.as_dvec3() * grid.cell;
    let Some((t0, t1)) = ray_box(origin, dir, lo, hi, t_min, t_max) else {
        return;
    };
    if !(t0 < t1) {
        return; // touches the grid in a single point
    }
    let dims = grid.dims.as_ivec3();
    // start voxel from the midpoint-free entry point, clamped into the grid against rounding
    let entry = origin + dir * t0;
    let mut v = ((entry - lo) / grid.cell)
        .floor()
        .as_ivec3()
        .clamp(IVec3::ZERO, dims - IVec3::ONE);
    let step = IVec3::new(sgn(dir.x), sgn(dir.y), sgn(dir.z));
    // boundary parameters are computed from absolute plane positions each time (no accumulated drift)
    let next_t = |v: IVec3, a: usize| -> f64 {
        if step[a] == 0 {
            return f64::INFINITY;
        }
        let plane = lo[a] + (v[a] + (step[a] > 0) as i32) as f64 * grid.cell;
        (plane - origin[a]) / dir[a]
    };
    let mut t_enter = t0;
    loop {
        let tm = [next_t(v, 0), next_t(v, 1), next_t(v, 2)];
        let t_next = tm[0].min(tm[1]).min(tm[2]);
        let t_exit = t_next.min(t1);
        // a zero-length stay (the ray starts exactly on a voxel face and leaves through it) is not a visit
        if t_exit > t_enter && !visit(v, t_enter, t_exit) || t_next >= t1 {
            return;
        }
        for a in 0..3 {
            if tm[a] == t_next {
                v[a] += step[a];
            }
        }
        if v.cmplt(IVec3::ZERO).any() || v.cmpge(dims).any() {
            return;
        }
        t_enter = t_next;
    }
}

fn sgn(x: f64) -> i32 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// The voxels crossed by the segment p0→p1, in order (see [`dda_traverse`]).
///
/// ```
/// use gregvox::geom::raster::{dda_segment, VoxelGrid};
/// use glam::{DVec3, IVec3, UVec3};
/// let g = VoxelGrid { origin: DVec3::ZERO, cell: 1.0, dims: UVec3::splat(4) };
/// let v = dda_segment(&g, DVec3::new(0.5, 0.5, 0.5), DVec3::new(2.5, 1.2, 0.5));
/// assert_eq!(v, vec![IVec3::new(0, 0, 0), IVec3::new(1, 0, 0), IVec3::new(1, 1, 0), IVec3::new(2, 1, 0)]);
/// ```
pub fn dda_segment(grid: &VoxelGrid, p0: DVec3, p1: DVec3) -> Vec<IVec3> {
    let mut out = Vec::new();
    dda_traverse(grid, p0, p1 - p0, 0.0, 1.0, |v, _, _| {
        out.push(v);
        true
    });
    out
}
