//! The host curvature kernel: mean and Gaussian curvature (H, K) of every Gregory patch on its (L+1)²
//! grid, the arithmetic of glsl/surface_curvature.comp in native code for devices that are CPUs, in the
//! same lanes as the host evaluator (a lane per patch, eight patches at one sample, threads across
//! batches).
//!
//! Invariants:
//! - The shader's operations in its order: world-space control points (no residuals, as the shader reads
//!   them), the rational interior points and their first and second partials with the 1e-6 corner guard,
//!   the row-by-row contraction of the frozen net for S_u, S_v, S_uu, S_uv, S_vv, the exact ∂Q and ∂²Q
//!   terms, the fundamental forms. Rust never fuses, so every SIMD width and thread count writes the same
//!   bits; against a Vulkan driver (which may fuse) and against the f64 reference
//!   ([`crate::geom::curvature::gaussian_mean_curvature`]), within the tolerances of
//!   tests/gregory_host.rs.
//! - Singular samples (S_u × S_v zero or non-finite, EG − F² ≤ 0) get (0, 0), as on the GPU.
//! - What depends on (u, v) alone — Bernstein values and both derivatives, the rational weights and their
//!   divide, the products of weights in the exact terms — is computed once per level (the same scalar
//!   operations as the shader's) and splat.
//! - Inputs are checked before any work ([`super::check`]): an error, never a panic.
use super::{
    batch_points, bern3, check, has_avx2, par_tasks, HostPatches, HostSimd, Lanes, Net,
    RationalWeights, F, LANES, P3,
};
use crate::error::Result;

/// Bernstein values, first and second derivatives at t (the shader's `bern3` with `dd`).
fn bern3_dd(t: f32) -> [[f32; 4]; 3] {
    let (b, d) = bern3(t);
    let s = 1.0 - t;
    [b, d, [6.0 * s, 18.0 * t - 12.0, 6.0 - 18.0 * t, 6.0 * t]]
}

/// The shader's `rational` weights at one sample: those of the evaluator (Q = (pa·a + pb·b)·inv,
/// ∂Q/∂u and ∂Q/∂v from fu, fv) and the second partials ∂Q = (pa − pb)·f for uu, uv, vv; at a corner Q = pa
/// and every partial 0.
#[derive(Clone, Copy, Default)]
struct RationalWeights2 {
    first: RationalWeights,
    /// fuu, fuv, fvv.
    second: [f32; 3],
}

impl RationalWeights2 {
    /// The shader's order: fuu = −(2·fu·au)·inv, fvv = −(2·fv·bv)·inv, fuv = au·bv·inv² − 2·fu·bv·inv.
    fn new(a: f32, b: f32, au: f32, bv: f32) -> Self {
        let first = RationalWeights::new(a, b, au, bv);
        let (fu, fv, inv) = (first.fu, first.fv, first.inv);
        let inv2 = inv * inv;
        RationalWeights2 {
            first,
            second: [
                -(2.0 * fu * au) * inv,
                au * bv * inv2 - 2.0 * fu * bv * inv,
                -(2.0 * fv * bv) * inv,
            ],
        }
    }

    /// The factors of (pa − pb) for ∂Q in the order u, v, uu, uv, vv.
    fn partials(&self) -> [f32; 5] {
        let [fuu, fuv, fvv] = self.second;
        [self.first.fu, self.first.fv, fuu, fuv, fvv]
    }
}

/// The weights of one sample.
#[derive(Clone, Copy, Default)]
struct SampleWeights2 {
    /// bern3 at u and at v: values, first, second derivatives.
    bu: [[f32; 4]; 3],
    bv: [[f32; 4]; 3],
    /// Cells (1,1), (2,1), (1,2), (2,2).
    rational: [RationalWeights2; 4],
    /// Per cell (i, j): w = b_i(u)·b_j(v), 2·b'_i(u)·b_j(v), b'_i(u)·b_j(v), b_i(u)·b'_j(v),
    /// 2·b_i(u)·b'_j(v) (the shader's products).
    exact: [[f32; 5]; 4],
}

/// The interior cells (column i, row j) in the shader's order.
const CELLS: [(usize, usize); 4] = [(1, 1), (2, 1), (1, 2), (2, 2)];

/// Bézier grid [row v][column u] in control point indices (`GRID` of the shader); the interior cells
/// (entries 5, 6, 9, 10) are the rational points.
const GRID: [usize; 16] = [0, 1, 7, 5, 2, 3, 9, 6, 16, 19, 13, 12, 15, 17, 11, 10];

fn level_table(level: u32) -> Vec<SampleWeights2> {
    let n = (level + 1) as usize;
    (0..n * n)
        .map(|s| {
            let (i, j) = (s % n, s / n);
            let (u, v) = (i as f32 / level as f32, j as f32 / level as f32);
            let (bu, bv) = (bern3_dd(u), bern3_dd(v));
            let exact = CELLS.map(|(i, j)| {
                [
                    bu[0][i] * bv[0][j],
                    2.0 * bu[1][i] * bv[0][j],
                    bu[1][i] * bv[0][j],
                    bu[0][i] * bv[1][j],
                    2.0 * bu[0][i] * bv[1][j],
                ]
            });
            SampleWeights2 {
                bu,
                bv,
                rational: [
                    RationalWeights2::new(u, v, 1.0, 1.0),
                    RationalWeights2::new(1.0 - u, v, -1.0, 1.0),
                    RationalWeights2::new(u, 1.0 - v, 1.0, -1.0),
                    RationalWeights2::new(1.0 - u, 1.0 - v, -1.0, -1.0),
                ],
                exact,
            }
        })
        .collect()
}

/// Checks the layout and writes (H, K) of every patch on its (L+1)² grid into `out`, in the vertex order
/// of [`super::evaluate`], on every core. Reads the world-space points only (`points` rows; residuals, if
/// any, are ignored, as glsl/surface_curvature.comp ignores them).
pub fn curvature(
    patches: &HostPatches,
    level: u32,
    simd: HostSimd,
    out: &mut [[f32; 2]],
) -> Result<()> {
    check(patches, level, out.len())?;
    let table = level_table(level);
    let world = HostPatches {
        residual_rows: 0,
        ..*patches
    };
    let avx2 = simd == HostSimd::Auto && has_avx2();
    par_tasks(out, table.len(), |first, chunk| {
        if avx2 {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: has_avx2() checked that this CPU executes AVX2 instructions.
            unsafe {
                curvature_task_avx2(&world, &table, first, chunk)
            }
        } else {
            curvature_task::<F>(&world, &table, first, chunk)
        }
    });
    Ok(())
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn curvature_task_avx2(
    p: &HostPatches,
    t: &[SampleWeights2],
    first: usize,
    out: &mut [[f32; 2]],
) {
    curvature_task::<super::Avx2>(p, t, first, out)
}

/// `dot` as GLSL and glam compute it: (x·x' + y·y') + z·z'.
#[inline(always)]
fn dot<L: Lanes>(a: P3<L>, b: P3<L>) -> L {
    a.x.mul(b.x).add(a.y.mul(b.y)).add(a.z.mul(b.z))
}

/// The patches `first..` whose (H, K) `out` holds, LANES at a time.
#[inline(always)]
fn curvature_task<L: Lanes>(
    p: &HostPatches,
    t: &[SampleWeights2],
    first: usize,
    out: &mut [[f32; 2]],
) {
    let per_patch = t.len();
    for (k, grids) in out.chunks_mut(LANES * per_patch).enumerate() {
        let batch = first + k * LANES;
        let valid = grids.len() / per_patch;
        // `p` has no residuals: the second array stays zero.
        let (mut world, mut unused): (Net, Net) = ([[0.0; LANES]; 60], [[0.0; LANES]; 60]);
        batch_points::<L>(p, batch, valid, &mut world, &mut unused);
        for (at, w) in t.iter().enumerate() {
            let hk = sample::<L>(&world, w);
            for l in 0..valid {
                grids[l * per_patch + at] = [hk[0][l], hk[1][l]];
            }
        }
    }
}

/// (H, K) at one sample for every lane (lane arrays; singular lanes (0, 0)).
#[inline(always)]
fn sample<L: Lanes>(world: &Net, w: &SampleWeights2) -> [F; 2] {
    macro_rules! cv {
        ($k:expr) => {
            P3::<L>::at(world, $k)
        };
    }
    let s = L::splat;
    let zero = P3::<L>::splat([0.0; 3]);
    // The rational points and their partials (u, v, uu, uv, vv), cells in the shader's order.
    let pairs = [(3, 4), (9, 8), (19, 18), (13, 14)];
    let mut q = [zero; 4];
    let mut dq = [[zero; 5]; 4];
    for c in 0..4 {
        let (pa, pb) = (cv!(pairs[c].0), cv!(pairs[c].1));
        let r = &w.rational[c];
        if r.first.corner {
            q[c] = pa;
            continue;
        }
        let f = r.partials();
        q[c] = pa
            .scale(s(r.first.a))
            .add(pb.scale(s(r.first.b)))
            .scale(s(r.first.inv));
        let diff = pa.sub(pb);
        for k in 0..5 {
            dq[c][k] = diff.scale(s(f[k]));
        }
    }
    // The frozen net contracted row by row: r_k = Σ_i p_i·bu[k][i], then into the five partials.
    let (mut su, mut sv, mut suu, mut suv, mut svv) = (zero, zero, zero, zero, zero);
    for j in 0..4 {
        let (mut r0, mut r1, mut r2) = (zero, zero, zero);
        for i in 0..4 {
            let p = match 4 * j + i {
                5 => q[0],
                6 => q[1],
                9 => q[2],
                10 => q[3],
                g => cv!(GRID[g]),
            };
            r0 = r0.add(p.scale(s(w.bu[0][i])));
            r1 = r1.add(p.scale(s(w.bu[1][i])));
            r2 = r2.add(p.scale(s(w.bu[2][i])));
        }
        su = su.add(r1.scale(s(w.bv[0][j])));
        sv = sv.add(r0.scale(s(w.bv[1][j])));
        suu = suu.add(r2.scale(s(w.bv[0][j])));
        suv = suv.add(r1.scale(s(w.bv[1][j])));
        svv = svv.add(r0.scale(s(w.bv[2][j])));
    }
    // The exact terms of the interior cells.
    for c in 0..4 {
        let x = &w.exact[c];
        let (e, euu, euv1, euv2, evv) = (s(x[0]), s(x[1]), s(x[2]), s(x[3]), s(x[4]));
        let d = &dq[c];
        su = su.add(d[0].scale(e));
        sv = sv.add(d[1].scale(e));
        suu = suu.add(d[0].scale(euu).add(d[2].scale(e)));
        suv = suv.add(d[1].scale(euv1).add(d[0].scale(euv2)).add(d[3].scale(e)));
        svv = svv.add(d[1].scale(evv).add(d[4].scale(e)));
    }
    let nc = su.cross(sv);
    let ln = nc.length();
    let n = P3 {
        x: nc.x.div(ln),
        y: nc.y.div(ln),
        z: nc.z.div(ln),
    };
    let (e, f, g) = (dot(su, su), dot(su, sv), dot(sv, sv));
    let (l, m, nn) = (dot(suu, n), dot(suv, n), dot(svv, n));
    let det = e.mul(g).sub(f.mul(f));
    let k = l.mul(nn).sub(m.mul(m)).div(det);
    let h = e
        .mul(nn)
        .sub(s(2.0).mul(f).mul(m))
        .add(g.mul(l))
        .div(s(2.0).mul(det));
    let (ln, det, mut h, mut k) = (ln.to_array(), det.to_array(), h.to_array(), k.to_array());
    for lane in 0..LANES {
        let regular = ln[lane] > 0.0 && ln[lane].abs() < f32::INFINITY && det[lane] > 0.0;
        if !regular {
            h[lane] = 0.0;
            k[lane] = 0.0;
        }
    }
    [h, k]
}
