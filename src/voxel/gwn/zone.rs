//! The near zone: the voxels whose centre lies within a distance `near` of a triangle, found from the
//! triangles (never by visiting the grid).
//!
//! Per triangle, columns are taken along the axis its plane faces most (largest |n_a|·h_a), over its box
//! grown by `near`; in each column only the centres within `near·|n|/|n_a|` of the plane along the axis
//! (at most a couple) are tested, by the exact point–triangle distance. A sliver (area below 1e-9 of its
//! longest edge squared) is taken as its three edges, each a capsule walked along its own dominant axis.
//! Cost: O(columns under the triangles' projections + zone voxels); nothing is allocated per grid voxel.
//!
//! Invariants: a voxel is in the zone iff its centre (local f64, (i + ½)·h) is within `near` of a triangle
//! by [`triangle_distance`], and *on the surface* when within [`ON_SURFACE`]·`near` of one (there the plain
//! sum decides: the winding number's value on a triangle is a convention of its formula); both lists are
//! sorted and hold each voxel once (linear index i + X·(j + Y·k)).
use super::kernel::{segment_distance2, triangle_distance};
use crate::voxel::grid::GridFrame;
use crate::voxel::surface::{cross, dot, sub};
use rayon::prelude::*;

/// The linear index of voxel `ijk` in `frame`.
#[inline]
pub fn linear(frame: &GridFrame, ijk: [u32; 3]) -> u64 {
    ijk[0] as u64 + frame.dims[0] as u64 * (ijk[1] as u64 + frame.dims[1] as u64 * ijk[2] as u64)
}

/// The voxel of linear index `i`.
#[inline]
pub fn unlinear(frame: &GridFrame, i: u64) -> [u32; 3] {
    let (x, y) = (frame.dims[0] as u64, frame.dims[1] as u64);
    [(i % x) as u32, ((i / x) % y) as u32, (i / (x * y)) as u32]
}

/// The local centre of voxel `ijk`: (i + ½)·size per axis.
#[inline]
pub fn centre(frame: &GridFrame, ijk: [u32; 3]) -> [f64; 3] {
    std::array::from_fn(|a| (ijk[a] as f64 + 0.5) * frame.voxel_size[a])
}

/// Voxel indices along axis `a` whose centres lie in [lo, hi] (local), clamped to the grid.
fn index_range(frame: &GridFrame, a: usize, lo: f64, hi: f64) -> Option<(u32, u32)> {
    let h = frame.voxel_size[a];
    let i0 = (lo / h - 0.5).ceil().max(0.0);
    let i1 = (hi / h - 0.5).floor().min(frame.dims[a] as f64 - 1.0);
    (i0 <= i1).then_some((i0 as u32, i1 as u32))
}

/// A centre within this fraction of `near` of a triangle is on the surface.
pub const ON_SURFACE: f64 = 1e-9;

/// The voxels within `near` of any triangle of `sets` (local f64 corners), and those on a triangle, sorted,
/// each once.
pub fn near_voxels(
    sets: &[&[[[f64; 3]; 3]]],
    frame: &GridFrame,
    near: f64,
) -> (Vec<u64>, Vec<u64>) {
    let found: Vec<(u64, bool)> = sets
        .par_iter()
        .flat_map(|set| set.par_iter())
        .flat_map_iter(|t| {
            let mut found = Vec::new();
            near_triangle(t, frame, near, &mut found);
            found
        })
        .collect();
    let mut zone: Vec<u64> = found.iter().map(|f| f.0).collect();
    let mut on: Vec<u64> = found.iter().filter(|f| f.1).map(|f| f.0).collect();
    for list in [&mut zone, &mut on] {
        list.par_sort_unstable();
        list.dedup();
    }
    (zone, on)
}

/// The voxels within `near` of triangle `t` (as [`near_voxels`]), appended to `found` with their
/// on-surface flag (unsorted; a sliver's voxel once per edge it is near).
pub(super) fn near_triangle(
    t: &[[f64; 3]; 3],
    frame: &GridFrame,
    near: f64,
    found: &mut Vec<(u64, bool)>,
) {
    let [a, b, c] = *t;
    let n = cross(sub(b, a), sub(c, a));
    let nn = dot(n, n).sqrt();
    let longest = [sub(b, a), sub(c, b), sub(a, c)]
        .iter()
        .map(|e| dot(*e, *e))
        .fold(0.0f64, f64::max);
    if nn <= 1e-9 * longest || nn == 0.0 {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            near_segment(p, q, frame, near, found);
        }
        return;
    }
    let h = frame.voxel_size;
    let axis = (0..3)
        .max_by(|&x, &y| (n[x].abs() * h[x]).total_cmp(&(n[y].abs() * h[y])))
        .expect("three axes");
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let lo = |k: usize| a[k].min(b[k]).min(c[k]) - near;
    let hi = |k: usize| a[k].max(b[k]).max(c[k]) + near;
    let (Some((u0, u1)), Some((v0, v1))) = (
        index_range(frame, u, lo(u), hi(u)),
        index_range(frame, v, lo(v), hi(v)),
    ) else {
        return;
    };
    let half = near * nn / n[axis].abs() * (1.0 + 1e-9);
    for iv in v0..=v1 {
        for iu in u0..=u1 {
            let (qu, qv) = ((iu as f64 + 0.5) * h[u], (iv as f64 + 0.5) * h[v]);
            let z = a[axis] - (n[u] * (qu - a[u]) + n[v] * (qv - a[v])) / n[axis];
            let Some((k0, k1)) = index_range(frame, axis, z - half, z + half) else {
                continue;
            };
            for k in k0..=k1 {
                let mut ijk = [0u32; 3];
                ijk[axis] = k;
                ijk[u] = iu;
                ijk[v] = iv;
                let d = triangle_distance(centre(frame, ijk), a, b, c);
                if d <= near {
                    found.push((linear(frame, ijk), d <= ON_SURFACE * near));
                }
            }
        }
    }
}

fn near_segment(
    p: [f64; 3],
    q: [f64; 3],
    frame: &GridFrame,
    near: f64,
    found: &mut Vec<(u64, bool)>,
) {
    let h = frame.voxel_size;
    let d = sub(q, p);
    let axis = (0..3)
        .max_by(|&x, &y| (d[x].abs() / h[x]).total_cmp(&(d[y].abs() / h[y])))
        .expect("three axes");
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let Some((k0, k1)) = index_range(
        frame,
        axis,
        p[axis].min(q[axis]) - near,
        p[axis].max(q[axis]) + near,
    ) else {
        return;
    };
    let len = dot(d, d).sqrt();
    // Across the axis the capsule reaches near·|d|/|d_a| from the line (its whole width when the segment
    // runs across the axis or is a point).
    let reach = if d[axis].abs() * 1e6 > len && len > 0.0 {
        near * len / d[axis].abs() * (1.0 + 1e-9)
    } else {
        near + len
    };
    for k in k0..=k1 {
        let z = (k as f64 + 0.5) * h[axis];
        let t = if d[axis] != 0.0 {
            ((z - p[axis]) / d[axis]).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let m: [f64; 3] = std::array::from_fn(|i| p[i] + t * d[i]);
        let (Some((u0, u1)), Some((v0, v1))) = (
            index_range(frame, u, m[u] - reach, m[u] + reach),
            index_range(frame, v, m[v] - reach, m[v] + reach),
        ) else {
            continue;
        };
        for iv in v0..=v1 {
            for iu in u0..=u1 {
                let mut ijk = [0u32; 3];
                ijk[axis] = k;
                ijk[u] = iu;
                ijk[v] = iv;
                let d2 = segment_distance2(centre(frame, ijk), p, q);
                if d2 <= near * near {
                    found.push((linear(frame, ijk), d2 <= (ON_SURFACE * near).powi(2)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_zone_is_every_centre_within_the_distance_and_no_other() {
        let frame = GridFrame {
            dims: [23, 17, 19],
            origin: [0.0; 3],
            voxel_size: [0.1, 0.13, 0.07],
        };
        let tris = [
            [[0.31, 0.2, 0.4], [1.9, 0.7, 0.9], [0.6, 1.8, 1.1]],
            // Axis-aligned, on a plane of centres.
            [
                [0.05, 0.065, 0.035],
                [2.0, 0.065, 0.035],
                [0.05, 2.0, 0.035],
            ],
            // A sliver and a point-like triangle.
            [[0.2, 0.2, 0.2], [1.5, 1.2, 1.0], [0.85, 0.7, 0.6]],
            [[1.0, 1.0, 0.5], [1.0, 1.0, 0.5], [1.0, 1.0, 0.5]],
        ];
        for near in [0.004, 0.03, 0.2] {
            let (got, on) = near_voxels(&[&tris], &frame, near);
            assert!(on.len() < got.len());
            let mut want = Vec::new();
            for k in 0..19 {
                for j in 0..17 {
                    for i in 0..23 {
                        let q = centre(&frame, [i, j, k]);
                        if tris
                            .iter()
                            .any(|t| triangle_distance(q, t[0], t[1], t[2]) <= near)
                        {
                            want.push(linear(&frame, [i, j, k]));
                        }
                    }
                }
            }
            assert_eq!(got, want, "near {near}");
            assert!(!want.is_empty());
        }
    }
}
