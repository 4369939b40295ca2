//! The host Gregory evaluator: the kernel of glsl/gregory_eval.comp (uniform grids) in native code, SIMD
//! across samples and threads across patches, for devices that are CPUs (lavapipe, SwiftShader), where it
//! writes the same vertices into the same (host-visible) buffer the Vulkan kernel would
//! ([`crate::engine::gregory::GregorySurface`] picks it; docs/benchmarks.md has why: llvmpipe's fixed cost
//! per workgroup and per invocation keeps any shader far from the machine's floor at low levels).
//!
//! Invariants:
//! - Operation for operation the shader's arithmetic (glsl/include/gregory.glsl, gregory_eval_body.glsl):
//!   patch-local points `(hi_k − hi_0) + (lo_k − lo_0)`, the clamped Bernstein weights of `gregory_bern3`,
//!   the rational interior points with the 1e-6 corner guard, the row contractions `gregory_row` in the same
//!   order, the exact-derivative corrections, the power-of-two rescale, the normal test, and the canonical
//!   edge cubic from the world-space points. Rust never fuses a multiply and an add, so every lane, every
//!   SIMD width and every thread count writes the same bits; against the f32 mirror
//!   ([`crate::geom::gregory::eval_generic`] on the local points) the bits differ at most in the sign of a
//!   zero; against a Vulkan driver, by that driver's rounding (it may fuse), within the tolerances of
//!   tests/gregory_host.rs.
//! - Shared edges: a sample on a patch edge is the edge's boundary cubic in its canonical direction with t
//!   from the canonical index (flag bit e), computed from the world-space points alone, so both patches of an
//!   edge write identical bits, as on the GPU.
//! - Samples whose S_u × S_v fails the normal test take the scalar fallback of
//!   [`crate::geom::gregory::normal_from_net_f32`] (hull diagonals, corner diagonals, +Z): never NaN for
//!   finite points.
//! - Inputs are checked before any work (rows in range, output length, level 1…64): an error, never a
//!   panic or an out-of-bounds read.
// Lane loops index several equal-length arrays at once, the form LLVM turns into one vector instruction.
#![allow(clippy::needless_range_loop)]
use crate::error::{Error, Result};
use crate::geom::gregory::normal_from_net_f32;
use glam::Vec3;
use rayon::prelude::*;

/// Samples evaluated together: one AVX2 register of f32 (two SSE registers without AVX2).
pub const LANES: usize = 8;

/// Highest level (as the Vulkan kernel's `MAX_LEVEL`).
pub const MAX_LEVEL: u32 = 64;

/// Corner guard of the rational points (`GREGORY_CORNER_EPS`).
const CORNER_EPS: f32 = 1e-6;

/// One output vertex, the layout of `SurfaceVertex` (glsl/include/surface_vertex.glsl): position xyz, 1,
/// normal xyz, 0.
pub type HostVertex = [f32; 8];

/// Which instruction set the host kernel runs with (the same bits either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HostSimd {
    /// AVX2 where the CPU has it, else the baseline.
    Auto,
    /// The target's baseline (SSE2 on x86-64): for tests that compare the two.
    Baseline,
}

/// The control points and patch layout the kernel reads, as the GPU buffers hold them.
#[derive(Clone, Copy)]
pub struct HostPatches<'a> {
    /// vec4 points (xyz, w unused); with residuals, rows `residual_rows..` hold each row's f32 residual.
    pub points: &'a [[f32; 4]],
    /// 0: no residuals; else point r's residual is `points[residual_rows + r]`.
    pub residual_rows: u32,
    /// Per patch, the 20 rows of its control points (GREGORY_BASIS order).
    pub patch_points: &'a [[u32; 20]],
    /// Per patch, bit e: edge e runs against its canonical direction.
    pub patch_flags: &'a [u32],
}

type F = [f32; LANES];

/// Per-level tables, one entry per sample of the (L+1)² grid (padded to whole lane groups): (u, v), the
/// Bernstein values and derivatives in u and in v, and the edge weights bern3(n/L). The same scalar
/// arithmetic as the shader's per-sample `gregory_bern3`, done once per level instead of once per sample.
struct LevelTable {
    level: u32,
    u: Vec<f32>,
    v: Vec<f32>,
    bu: [Vec<f32>; 4],
    du: [Vec<f32>; 4],
    bv: [Vec<f32>; 4],
    dv: [Vec<f32>; 4],
    /// bern3(n/L).b for n = 0…L.
    edge: Vec<[f32; 4]>,
}

/// `gregory_bern3`: cubic Bernstein values and derivatives at t, in the shader's operation order.
#[inline]
fn bern3(t: f32) -> ([f32; 4], [f32; 4]) {
    let s = 1.0 - t;
    (
        [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t],
        [
            -3.0 * s * s,
            3.0 * s * s - 6.0 * t * s,
            6.0 * t * s - 3.0 * t * t,
            3.0 * t * t,
        ],
    )
}

impl LevelTable {
    fn new(level: u32) -> Self {
        let n = (level + 1) as usize;
        let padded = (n * n).div_ceil(LANES) * LANES;
        let param = |k: usize| (k as f32 / level as f32).clamp(0.0, 1.0);
        let mut t = LevelTable {
            level,
            u: vec![0.0; padded],
            v: vec![0.0; padded],
            bu: std::array::from_fn(|_| vec![0.0; padded]),
            du: std::array::from_fn(|_| vec![0.0; padded]),
            bv: std::array::from_fn(|_| vec![0.0; padded]),
            dv: std::array::from_fn(|_| vec![0.0; padded]),
            edge: (0..n).map(|k| bern3(k as f32 / level as f32).0).collect(),
        };
        for s in 0..padded {
            // Padding lanes repeat the last sample: finite values, never written out.
            let s_in = s.min(n * n - 1);
            let (i, j) = (s_in % n, s_in / n);
            let (u, v) = (param(i), param(j));
            let (bu, du) = bern3(u);
            let (bv, dv) = bern3(v);
            t.u[s] = u;
            t.v[s] = v;
            for k in 0..4 {
                t.bu[k][s] = bu[k];
                t.du[k][s] = du[k];
                t.bv[k][s] = bv[k];
                t.dv[k][s] = dv[k];
            }
        }
        t
    }
}

/// Checks the layout and evaluates every patch on its (L+1)² grid into `out` (patch-major, rows of u
/// inner: vertex `p·(L+1)² + j·(L+1) + i` at (i/L, j/L)), on every core. `canonical`: edge samples from
/// the canonical edge cubic (see the module invariants).
pub fn evaluate(
    patches: &HostPatches,
    level: u32,
    canonical: bool,
    simd: HostSimd,
    out: &mut [HostVertex],
) -> Result<()> {
    check(patches, level, out.len())?;
    let table = LevelTable::new(level);
    let per_patch = ((level + 1) * (level + 1)) as usize;
    // Tasks of about 4,096 vertices: enough to hide the task overhead, enough tasks to balance the cores.
    let patches_per_task = (4096 / per_patch).max(1);
    let avx2 = simd == HostSimd::Auto && has_avx2();
    out.par_chunks_mut(per_patch * patches_per_task)
        .enumerate()
        .for_each(|(task, chunk)| {
            let first = task * patches_per_task;
            if avx2 {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: has_avx2() checked that this CPU executes AVX2 instructions.
                unsafe {
                    eval_task_avx2(patches, &table, canonical, first, chunk)
                }
            } else {
                eval_task(patches, &table, canonical, first, chunk)
            }
        });
    Ok(())
}

fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn check(p: &HostPatches, level: u32, out_len: usize) -> Result<()> {
    if !(1..=MAX_LEVEL).contains(&level) {
        return Err(Error::Invalid(format!(
            "tessellation level {level} is outside 1…{MAX_LEVEL}"
        )));
    }
    if p.patch_flags.len() != p.patch_points.len() {
        return Err(Error::Invalid(format!(
            "{} patch flags for {} patches",
            p.patch_flags.len(),
            p.patch_points.len()
        )));
    }
    let per_patch = ((level + 1) * (level + 1)) as usize;
    let want = p.patch_points.len().checked_mul(per_patch);
    if want != Some(out_len) {
        return Err(Error::Invalid(format!(
            "the output holds {out_len} vertices, {} patches at level {level} need {}",
            p.patch_points.len(),
            p.patch_points.len() as u128 * per_patch as u128
        )));
    }
    let rows = p.points.len() as u64;
    let reach = p.residual_rows as u64;
    if let Some(bad) = p
        .patch_points
        .iter()
        .flatten()
        .find(|&&r| r as u64 + reach >= rows)
    {
        return Err(Error::Invalid(format!(
            "patch point row {bad} (residuals from row {}) is past the {rows} points",
            p.residual_rows
        )));
    }
    Ok(())
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn eval_task_avx2(
    p: &HostPatches,
    t: &LevelTable,
    canonical: bool,
    first: usize,
    out: &mut [HostVertex],
) {
    eval_task(p, t, canonical, first, out)
}

/// The patches `first..` whose vertices `out` holds.
#[inline(always)]
fn eval_task(
    p: &HostPatches,
    t: &LevelTable,
    canonical: bool,
    first: usize,
    out: &mut [HostVertex],
) {
    let per_patch = ((t.level + 1) * (t.level + 1)) as usize;
    for (k, grid) in out.chunks_exact_mut(per_patch).enumerate() {
        eval_patch(p, t, canonical, first + k, grid);
    }
}

// ---- lane arithmetic: element-wise loops over [f32; LANES], which LLVM compiles to vector instructions ----

#[inline(always)]
fn splat(x: f32) -> F {
    [x; LANES]
}

macro_rules! lanewise {
    ($name:ident, $op:tt) => {
        #[inline(always)]
        fn $name(a: F, b: F) -> F {
            let mut r = [0.0; LANES];
            for k in 0..LANES {
                r[k] = a[k] $op b[k];
            }
            r
        }
    };
}
lanewise!(add, +);
lanewise!(sub, -);
lanewise!(mul, *);
lanewise!(div, /);

#[inline(always)]
fn neg(a: F) -> F {
    let mut r = [0.0; LANES];
    for k in 0..LANES {
        r[k] = -a[k];
    }
    r
}

#[inline(always)]
fn sqrt(a: F) -> F {
    let mut r = [0.0; LANES];
    for k in 0..LANES {
        r[k] = a[k].sqrt();
    }
    r
}

/// A point per lane.
#[derive(Clone, Copy)]
struct P3 {
    x: F,
    y: F,
    z: F,
}

impl P3 {
    #[inline(always)]
    fn splat(p: [f32; 3]) -> P3 {
        P3 {
            x: splat(p[0]),
            y: splat(p[1]),
            z: splat(p[2]),
        }
    }
    #[inline(always)]
    fn add(self, o: P3) -> P3 {
        P3 {
            x: add(self.x, o.x),
            y: add(self.y, o.y),
            z: add(self.z, o.z),
        }
    }
    #[inline(always)]
    fn sub(self, o: P3) -> P3 {
        P3 {
            x: sub(self.x, o.x),
            y: sub(self.y, o.y),
            z: sub(self.z, o.z),
        }
    }
    #[inline(always)]
    fn scale(self, s: F) -> P3 {
        P3 {
            x: mul(self.x, s),
            y: mul(self.y, s),
            z: mul(self.z, s),
        }
    }
    #[inline(always)]
    fn lane(&self, k: usize) -> Vec3 {
        Vec3::new(self.x[k], self.y[k], self.z[k])
    }
    /// `cross` as GLSL and glam compute it.
    #[inline(always)]
    fn cross(self, o: P3) -> P3 {
        P3 {
            x: sub(mul(self.y, o.z), mul(o.y, self.z)),
            y: sub(mul(self.z, o.x), mul(o.z, self.x)),
            z: sub(mul(self.x, o.y), mul(o.x, self.y)),
        }
    }
    /// `length`: sqrt((x·x + y·y) + z·z).
    #[inline(always)]
    fn length(self) -> F {
        sqrt(add(
            add(mul(self.x, self.x), mul(self.y, self.y)),
            mul(self.z, self.z),
        ))
    }
}

/// Lane-wise select: `m[k]` ? a : b.
#[inline(always)]
fn select(m: [bool; LANES], a: P3, b: P3) -> P3 {
    let mut r = b;
    for k in 0..LANES {
        if m[k] {
            r.x[k] = a.x[k];
            r.y[k] = a.y[k];
            r.z[k] = a.z[k];
        }
    }
    r
}

/// `gregory_row`: ((a·w0 + b·w1) + c·w2) + d·w3.
#[inline(always)]
fn row(a: P3, b: P3, c: P3, d: P3, w: &[F; 4]) -> P3 {
    a.scale(w[0])
        .add(b.scale(w[1]))
        .add(c.scale(w[2]))
        .add(d.scale(w[3]))
}

/// `gregory_rational` with constant signs (∂a/∂u = au, ∂b/∂v = bv): (Q, Q_u, Q_v).
#[inline(always)]
fn rational(pa: P3, pb: P3, a: F, b: F, au: f32, bv: f32) -> (P3, P3, P3) {
    let d = add(a, b);
    let inv = div(splat(1.0), d);
    let q = pa.scale(a).add(pb.scale(b)).scale(inv);
    let diff = pa.sub(pb);
    let inv2 = mul(inv, inv);
    let fu = mul(mul(splat(au), b), inv2);
    let fv = mul(neg(mul(a, splat(bv))), inv2);
    let mut guard = [false; LANES];
    for k in 0..LANES {
        guard[k] = d[k] < CORNER_EPS;
    }
    let zero = P3::splat([0.0; 3]);
    (
        select(guard, pa, q),
        select(guard, zero, diff.scale(fu)),
        select(guard, zero, diff.scale(fv)),
    )
}

/// `pow2_rescale` as geom::gregory's `rescaled`: both vectors times 2^−e, the largest component's
/// exponent brought to [½, 1); zero, subnormal, non-finite and near-overflow maxima are left alone (×1).
#[inline(always)]
fn pow2_scale(a: P3, b: P3) -> F {
    let mut k = [1.0f32; LANES];
    for l in 0..LANES {
        let m = a.x[l]
            .abs()
            .max(a.y[l].abs())
            .max(a.z[l].abs())
            .max(b.x[l].abs().max(b.y[l].abs()).max(b.z[l].abs()));
        let exp = (m.to_bits() >> 23) & 0xff;
        // m = f·2^e, f in [½, 1): e = exp − 126; 2^−e has the biased exponent 253 − exp (≥ 1 to be normal).
        if exp != 0 && exp != 255 && exp < 253 {
            k[l] = f32::from_bits((253 - exp) << 23);
        }
    }
    k
}

/// One patch's grid (see [`evaluate`]).
#[inline(always)]
fn eval_patch(
    p: &HostPatches,
    t: &LevelTable,
    canonical: bool,
    patch: usize,
    out: &mut [HostVertex],
) {
    let rows = &p.patch_points[patch];
    let flags = p.patch_flags[patch];
    let level = t.level as usize;
    let n = level + 1;
    // World points and residuals, then the patch-local points (hi_k − hi_0) + (lo_k − lo_0).
    let mut world = [[0.0f32; 3]; 20];
    let mut lo = [[0.0f32; 3]; 20];
    for k in 0..20 {
        let q = p.points[rows[k] as usize];
        world[k] = [q[0], q[1], q[2]];
        if p.residual_rows > 0 {
            let r = p.points[(p.residual_rows + rows[k]) as usize];
            lo[k] = [r[0], r[1], r[2]];
        }
    }
    let origin = world[0];
    let mut cv = [P3::splat([0.0; 3]); 20];
    for k in 0..20 {
        let c: [f32; 3] =
            std::array::from_fn(|a| (world[k][a] - origin[a]) + (lo[k][a] - lo[0][a]));
        cv[k] = P3::splat(c);
    }
    let origin3 = P3::splat(origin);
    let one = splat(1.0);
    let per_patch = n * n;
    for g in (0..per_patch).step_by(LANES) {
        let load = |v: &[f32]| -> F { v[g..g + LANES].try_into().expect("padded table") };
        let (u, v) = (load(&t.u), load(&t.v));
        let bu: [F; 4] = std::array::from_fn(|k| load(&t.bu[k]));
        let du: [F; 4] = std::array::from_fn(|k| load(&t.du[k]));
        let bv: [F; 4] = std::array::from_fn(|k| load(&t.bv[k]));
        let dv: [F; 4] = std::array::from_fn(|k| load(&t.dv[k]));
        let (uu, vv) = (sub(one, u), sub(one, v));
        // Interior cells Q11 (1,1), Q21 (2,1), Q12 (1,2), Q22 (2,2).
        let (q11, u11, v11) = rational(cv[3], cv[4], u, v, 1.0, 1.0);
        let (q21, u21, v21) = rational(cv[9], cv[8], uu, v, -1.0, 1.0);
        let (q12, u12, v12) = rational(cv[19], cv[18], u, vv, 1.0, -1.0);
        let (q22, u22, v22) = rational(cv[13], cv[14], uu, vv, -1.0, -1.0);
        let r0 = row(cv[0], cv[1], cv[7], cv[5], &bu);
        let r1 = row(cv[2], q11, q21, cv[6], &bu);
        let r2 = row(cv[16], q12, q22, cv[12], &bu);
        let r3 = row(cv[15], cv[17], cv[11], cv[10], &bu);
        let d0 = row(cv[0], cv[1], cv[7], cv[5], &du);
        let d1 = row(cv[2], q11, q21, cv[6], &du);
        let d2 = row(cv[16], q12, q22, cv[12], &du);
        let d3 = row(cv[15], cv[17], cv[11], cv[10], &du);
        let pos = row(r0, r1, r2, r3, &bv).add(origin3);
        let mut su = row(d0, d1, d2, d3, &bv);
        let mut sv = row(r0, r1, r2, r3, &dv);
        // Exact-derivative terms Σ B_i(u) B_j(v) ∂Q_ij, in the shader's order Q11, Q21, Q12, Q22.
        for (qu, qv, w) in [
            (u11, v11, mul(bu[1], bv[1])),
            (u21, v21, mul(bu[2], bv[1])),
            (u12, v12, mul(bu[1], bv[2])),
            (u22, v22, mul(bu[2], bv[2])),
        ] {
            su = su.add(qu.scale(w));
            sv = sv.add(qv.scale(w));
        }
        // The normal: S_u × S_v after the power-of-two rescale, tested as the shader tests it.
        let k = pow2_scale(su, sv);
        let (rsu, rsv) = (su.scale(k), sv.scale(k));
        let nrm = rsu.cross(rsv);
        let ln = nrm.length();
        let scale = add(rsu.length(), rsv.length());
        let limit = mul(mul(splat(1e-5), scale), scale);
        let unit = P3 {
            x: div(nrm.x, ln),
            y: div(nrm.y, ln),
            z: div(nrm.z, ln),
        };
        let lanes = LANES.min(per_patch - g);
        for l in 0..lanes {
            let normal = if ln[l] > limit[l] && ln[l].is_finite() {
                [unit.x[l], unit.y[l], unit.z[l]]
            } else {
                let lane = |q: &P3| q.lane(l);
                let c = |k: usize| cv[k].lane(l);
                let net = [
                    [c(0), c(1), c(7), c(5)],
                    [c(2), lane(&q11), lane(&q21), c(6)],
                    [c(16), lane(&q12), lane(&q22), c(12)],
                    [c(15), c(17), c(11), c(10)],
                ];
                normal_from_net_f32(&net, su.lane(l), sv.lane(l), u[l], v[l]).to_array()
            };
            out[g + l] = [
                pos.x[l], pos.y[l], pos.z[l], 1.0, normal[0], normal[1], normal[2], 0.0,
            ];
        }
    }
    if canonical {
        // Edge samples: the canonical boundary cubic replaces the position (rows j = 0, L; columns i = 0, L).
        for m in 0..n {
            out[m][..3].copy_from_slice(&edge_point(&world, flags, 0, m, t));
            out[level * n + m][..3].copy_from_slice(&edge_point(&world, flags, 2, m, t));
        }
        for m in 1..level {
            out[m * n][..3].copy_from_slice(&edge_point(&world, flags, 3, m, t));
            out[m * n + level][..3].copy_from_slice(&edge_point(&world, flags, 1, m, t));
        }
    }
}

/// `edge_point`: sample m of edge e from the world-space boundary points, in the canonical direction.
#[inline(always)]
fn edge_point(world: &[[f32; 3]; 20], flags: u32, e: usize, m: usize, t: &LevelTable) -> [f32; 3] {
    const EDGES: [[usize; 4]; 4] = [
        [0, 1, 7, 5],
        [5, 6, 12, 10],
        [15, 17, 11, 10],
        [0, 2, 16, 15],
    ];
    let [a, b, c, d] = EDGES[e].map(|k| world[k]);
    let level = t.level as usize;
    let (p, w) = if (flags >> e) & 1 == 1 {
        ([d, c, b, a], t.edge[level - m])
    } else {
        ([a, b, c, d], t.edge[m])
    };
    std::array::from_fn(|x| p[0][x] * w[0] + p[1][x] * w[1] + p[2][x] * w[2] + p[3][x] * w[3])
}
