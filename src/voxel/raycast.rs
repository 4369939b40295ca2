//! The CPU reference of the voxel ray caster (glsl/voxel_raycast.comp): one ray per pixel through a bit grid,
//! walked with the Amanatides–Woo 3D DDA on two levels (4³ bricks, then voxels inside occupied bricks, so empty
//! space costs a quarter of the steps), shaded Lambert + ambient by the normal of the face the ray entered
//! the hit voxel through.
//!
//! Invariants (shared with the shader, operation for operation, all in `f32`):
//! - Rays live in grid units: `o = (eye − origin)/pitch`, direction `d` = the normalized world direction (the
//!   grid is a uniformly scaled, axis-aligned copy of world space); a direction component smaller than
//!   [`MIN_DIR`] in magnitude is replaced by ±`MIN_DIR` so no slab test divides by zero.
//! - Pixel (x, y) looks through `forward + ndc_x·right − ndc_y·up` at its centre, y down (Vulkan's window
//!   convention), so the picture matches the raster path's `Orbit::view_proj` when built by
//!   [`RayCamera::look_at`] with the same field of view.
//! - Ties: the entry face is the first axis (x, y, z) of the largest slab entry; each DDA step (brick or
//!   voxel) advances the first axis of the smallest `t_max`; a brick's voxel walk starts in the cell of the
//!   brick's entry point clamped into the brick, with the brick's entry face. A ray starting inside the box has no entry face and is shaded with the
//!   normal `−d`.
//! - A hit reports the voxel's linear index `(k·R + j)·R + i`; a miss reports [`MISS`] and the background.
use crate::voxel::grid::VoxelGrid;

/// Index reported for rays that hit nothing.
pub const MISS: u32 = u32::MAX;

/// Smallest direction component magnitude (grid units per unit length).
pub const MIN_DIR: f32 = 1e-12;

/// A pinhole camera for the ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCamera {
    pub eye: [f32; 3],
    /// Unit view direction.
    pub forward: [f32; 3],
    /// Camera right, scaled by `tan(fovy/2)·aspect`.
    pub right: [f32; 3],
    /// Camera up, scaled by `tan(fovy/2)`.
    pub up: [f32; 3],
}

impl RayCamera {
    /// Looks from `eye` at `target` with `world_up` up, vertical field of view `fovy` (radians), `aspect` =
    /// width / height — the camera of `glam::Mat4::look_at_rh` + `perspective_rh` with the y flip.
    pub fn look_at(
        eye: glam::Vec3,
        target: glam::Vec3,
        world_up: glam::Vec3,
        fovy: f32,
        aspect: f32,
    ) -> Self {
        let f = (target - eye).normalize();
        let r = f.cross(world_up).normalize();
        let u = r.cross(f);
        let h = (0.5 * fovy).tan();
        RayCamera {
            eye: eye.to_array(),
            forward: f.to_array(),
            right: (r * h * aspect).to_array(),
            up: (u * h).to_array(),
        }
    }
}

/// Shading of the ray caster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayShading {
    /// Unit direction towards the light.
    pub light: [f32; 3],
    /// Ambient fraction (0…1).
    pub ambient: f32,
    /// Voxel colour (linear 0…1).
    pub color: [f32; 3],
    /// Background colour (0…1).
    pub background: [f32; 3],
}

/// One pixel's result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayHit {
    /// Linear voxel index or [`MISS`].
    pub voxel: u32,
    /// RGBA8.
    pub rgba: [u8; 4],
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The ray direction (world, unit) of pixel (x, y) of a `width`×`height` image.
pub fn pixel_direction(cam: &RayCamera, x: u32, y: u32, width: u32, height: u32) -> [f32; 3] {
    let nx = (x as f32 + 0.5) / width as f32 * 2.0 - 1.0;
    let ny = (y as f32 + 0.5) / height as f32 * 2.0 - 1.0;
    let d: [f32; 3] = std::array::from_fn(|a| cam.forward[a] + nx * cam.right[a] - ny * cam.up[a]);
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    [d[0] / len, d[1] / len, d[2] / len]
}

/// Quantizes a colour channel as a UNORM8 store does (round to nearest).
pub fn unorm8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Edge of a brick, the coarse cell of the two-level DDA (voxels per side).
pub const BRICK: u32 = 4;

/// Brick occupancy of a grid: one flag per `BRICK`³ block (the last blocks may stick out of the grid), index
/// `(bk·NB + bj)·NB + bi` with `NB = ceil(R / BRICK)`; what glsl/voxel_raycast_bricks.comp computes. The ray
/// caster draws cubic R³ grids (the demo's); R is `dims[0]`.
pub fn brick_occupancy(grid: &VoxelGrid) -> Vec<bool> {
    debug_assert!(
        grid.frame.cubic_res().is_some(),
        "the ray caster draws cubic grids"
    );
    let r = grid.frame.dims[0];
    let nb = r.div_ceil(BRICK);
    let mut out = vec![false; (nb * nb * nb) as usize];
    for k in 0..r {
        for j in 0..r {
            for i in 0..r {
                if grid.get(i, j, k) {
                    out[(((k / BRICK) * nb + j / BRICK) * nb + i / BRICK) as usize] = true;
                }
            }
        }
    }
    out
}

fn argmin(t: &[f32; 3]) -> usize {
    if t[0] <= t[1] && t[0] <= t[2] {
        0
    } else if t[1] <= t[2] {
        1
    } else {
        2
    }
}

/// Casts one ray: origin `eye` (world), unit direction `dir` (world) through `solid(i, j, k)` on a grid of `res`
/// voxels per side at `origin` with `pitch`. `occupied(bi, bj, bk)` must be true for every brick holding a solid
/// voxel (it may be true for more: `|_, _, _| true` walks every voxel).
///
/// The walk has two levels: a DDA over bricks skips empty ones; in an occupied brick a voxel DDA starts at the
/// brick's entry point (its cell clamped into the brick) and runs until it hits or leaves the brick.
///
/// ```
/// use gregvox::voxel::raycast::{cast_ray, RayShading, MISS};
/// let shading = RayShading { light: [0.0, 0.0, 1.0], ambient: 0.25, color: [1.0; 3], background: [0.0; 3] };
/// // A 2³ grid with only voxel (1, 1, 1) solid, seen from straight above: entered through its top face (+z),
/// // which faces the light, so it is fully lit, times the checker's 0.9 for odd i + j + k: 0.9 · 255 → 230.
/// let solid = |i: u32, j: u32, k: u32| (i, j, k) == (1, 1, 1);
/// let all = |_: u32, _: u32, _: u32| true;
/// let hit = cast_ray(&solid, &all, 2, [0.0; 3], 1.0, [1.5, 1.5, 5.0], [0.0, 0.0, -1.0], &shading);
/// assert_eq!(hit.voxel, (1 * 2 + 1) * 2 + 1);
/// assert_eq!(hit.rgba, [230, 230, 230, 255]);
/// // Beside the voxel the ray passes through empty cells and leaves the grid.
/// let miss = cast_ray(&solid, &all, 2, [0.0; 3], 1.0, [0.5, 0.5, 5.0], [0.0, 0.0, -1.0], &shading);
/// assert_eq!(miss.voxel, MISS);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn cast_ray(
    solid: &dyn Fn(u32, u32, u32) -> bool,
    occupied: &dyn Fn(u32, u32, u32) -> bool,
    res: u32,
    origin: [f32; 3],
    pitch: f32,
    eye: [f32; 3],
    dir: [f32; 3],
    s: &RayShading,
) -> RayHit {
    let background = RayHit {
        voxel: MISS,
        rgba: [
            unorm8(s.background[0]),
            unorm8(s.background[1]),
            unorm8(s.background[2]),
            255,
        ],
    };
    let inv_pitch = 1.0 / pitch;
    let rel = sub(eye, origin);
    let o: [f32; 3] = std::array::from_fn(|a| rel[a] * inv_pitch);
    let d: [f32; 3] = std::array::from_fn(|a| {
        if dir[a].abs() < MIN_DIR {
            if dir[a] < 0.0 {
                -MIN_DIR
            } else {
                MIN_DIR
            }
        } else {
            dir[a]
        }
    });
    let inv: [f32; 3] = std::array::from_fn(|a| 1.0 / d[a]);
    let r = res as f32;
    let t0: [f32; 3] = std::array::from_fn(|a| (0.0 - o[a]) * inv[a]);
    let t1: [f32; 3] = std::array::from_fn(|a| (r - o[a]) * inv[a]);
    let tmin: [f32; 3] = std::array::from_fn(|a| t0[a].min(t1[a]));
    let tmax: [f32; 3] = std::array::from_fn(|a| t0[a].max(t1[a]));
    let t_enter = tmin[0].max(tmin[1]).max(tmin[2]);
    let t_exit = tmax[0].min(tmax[1]).min(tmax[2]);
    let t_start = t_enter.max(0.0);
    if t_exit < t_start {
        return background;
    }
    // The entry face: the first axis of the largest slab entry (none when the eye is inside).
    let mut axis_b: i32 = if t_enter < 0.0 {
        -1
    } else if tmin[0] >= tmin[1] && tmin[0] >= tmin[2] {
        0
    } else if tmin[1] >= tmin[2] {
        1
    } else {
        2
    };
    let step: [i32; 3] = std::array::from_fn(|a| if d[a] > 0.0 { 1 } else { -1 });
    let up: [i32; 3] = std::array::from_fn(|a| if step[a] > 0 { 1 } else { 0 });
    let b = BRICK as i32;
    let bf = BRICK as f32;
    let nb = res.div_ceil(BRICK) as i32;
    let t_delta: [f32; 3] = std::array::from_fn(|a| inv[a].abs());
    let t_delta_b: [f32; 3] = std::array::from_fn(|a| bf * inv[a].abs());
    let mut brick: [i32; 3] = std::array::from_fn(|a| {
        let p = o[a] + d[a] * t_start;
        ((p / bf).floor() as i32).clamp(0, nb - 1)
    });
    let mut t_max_b: [f32; 3] =
        std::array::from_fn(|a| (((brick[a] + up[a]) * b) as f32 - o[a]) * inv[a]);
    let mut t_in = t_start;
    for _ in 0..3 * nb + 3 {
        if occupied(brick[0] as u32, brick[1] as u32, brick[2] as u32) {
            let lo: [i32; 3] = std::array::from_fn(|a| brick[a] * b);
            let hi: [i32; 3] = std::array::from_fn(|a| (brick[a] * b + b).min(res as i32));
            let mut cell: [i32; 3] = std::array::from_fn(|a| {
                let p = o[a] + d[a] * t_in;
                (p.floor() as i32).clamp(lo[a], hi[a] - 1)
            });
            let mut t_max: [f32; 3] =
                std::array::from_fn(|a| ((cell[a] + up[a]) as f32 - o[a]) * inv[a]);
            let mut axis = axis_b;
            for _ in 0..3 * BRICK + 3 {
                let [i, j, k] = cell.map(|c| c as u32);
                if solid(i, j, k) {
                    let n: [f32; 3] = if axis < 0 {
                        [-d[0], -d[1], -d[2]]
                    } else {
                        std::array::from_fn(|a| {
                            if a as i32 == axis {
                                -step[a] as f32
                            } else {
                                0.0
                            }
                        })
                    };
                    let lambert =
                        (n[0] * s.light[0] + n[1] * s.light[1] + n[2] * s.light[2]).max(0.0);
                    // A faint checker by voxel parity makes single voxels readable on flat faces.
                    let tint = if (i + j + k) & 1 == 1 { 0.9 } else { 1.0 };
                    let f = (s.ambient + (1.0 - s.ambient) * lambert) * tint;
                    return RayHit {
                        voxel: (k * res + j) * res + i,
                        rgba: [
                            unorm8(s.color[0] * f),
                            unorm8(s.color[1] * f),
                            unorm8(s.color[2] * f),
                            255,
                        ],
                    };
                }
                let a = argmin(&t_max);
                cell[a] += step[a];
                if cell[a] < lo[a] || cell[a] >= hi[a] {
                    break;
                }
                t_max[a] += t_delta[a];
                axis = a as i32;
            }
        }
        let a = argmin(&t_max_b);
        t_in = t_max_b[a];
        brick[a] += step[a];
        if brick[a] < 0 || brick[a] >= nb {
            return background;
        }
        t_max_b[a] += t_delta_b[a];
        axis_b = a as i32;
    }
    background
}

/// Ray casts `grid` (cubic, as [`brick_occupancy`]) into a `width`×`height` image: one [`RayHit`] per pixel,
/// row-major from the top left.
pub fn raycast_grid(
    grid: &VoxelGrid,
    cam: &RayCamera,
    width: u32,
    height: u32,
    s: &RayShading,
) -> Vec<RayHit> {
    let f = &grid.frame;
    let origin = f.origin.map(|x| x as f32);
    let pitch = f.voxel_size[0] as f32;
    let solid = |i: u32, j: u32, k: u32| grid.get(i, j, k);
    let bricks = brick_occupancy(grid);
    let res = f.dims[0];
    let nb = res.div_ceil(BRICK);
    let occupied = |i: u32, j: u32, k: u32| bricks[((k * nb + j) * nb + i) as usize];
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        for x in 0..width {
            let d = pixel_direction(cam, x, y, width, height);
            out.push(cast_ray(
                &solid, &occupied, res, origin, pitch, cam.eye, d, s,
            ));
        }
    }
    out
}
