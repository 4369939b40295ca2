//! The host Gregory evaluator: the kernel of glsl/gregory_eval.comp (uniform grids) in native code, SIMD
//! across patches (a lane per patch, eight patches at one sample) and threads across batches of patches,
//! for devices that are CPUs (lavapipe, SwiftShader), where it
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
//! - The kernel is written once, generic over its lane arithmetic (trait `Lanes`): `[f32; 8]` runs it, and
//!   [`operation_counts`] runs the same code on counting lanes, so the bench's flop counts are the code's.
//! - Speed (docs/benchmarks.md, suite `gregory`): a lane per patch, so no lane is padding at any level
//!   (25 samples at level 4 filled 32 sample lanes) and what depends on (u, v) alone — Bernstein weights,
//!   the rational points' weights and their divide, the exact-derivative weights — is a table scalar
//!   splat, not lane work; the u-only terms of the contraction once per column, not per sample; on AVX2
//!   the lanes are explicit `__m256` instructions (`Avx2`: LLVM's vectorizers, given element-wise
//!   loops, vectorized across a point's x, y, z instead), points transposed into lanes and vertices out
//!   of lanes by register transposes; the fallback normal recomputes its sample out of line, so the hot
//!   loop keeps no state for it; nothing on the lane path is a closure or `array::map` (LLVM may leave
//!   those out of line, compiled without the caller's AVX2); the next batch's points are prefetched.
// Lane loops index several equal-length arrays at once, the form LLVM turns into one vector instruction.
#![allow(clippy::needless_range_loop)]
use crate::error::{Error, Result};
use crate::geom::gregory::normal_from_net_f32;
use glam::Vec3;
use rayon::prelude::*;

mod curvature;
pub use curvature::curvature;

/// Patches evaluated together: one AVX2 register of f32 (two SSE registers without AVX2).
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
    /// AVX2 where the CPU has it, else the baseline. (AVX-512VL, tried for its 32 registers, ran the
    /// same 8-lane code 20 % slower on a Zen 4 core.)
    Auto,
    /// The target's baseline (SSE2 on x86-64): for tests that compare the two.
    Baseline,
}

/// The surface at located (patch, u, v) points ([`crate::surface::PtexMap::locate_all`]) from the points
/// `p` holds: each point's f32 row plus its residual in f64, evaluated with exact first and second
/// derivatives ([`crate::geom::gregory::eval_generic`]), the derivatives mapped back to the ptex face's
/// (u, v) by the located Jacobian; `[position, du, dv, duu, duv, dvv]` per point, in f32, every core. The host counterpart of
/// glsl/patch_at.comp (`Surface::evaluate_at` on CPU devices). Cost: 20 gathered points per query.
pub fn evaluate_at(p: &HostPatches, located: &[crate::surface::Located]) -> Vec<[[f32; 3]; 6]> {
    use glam::DVec3;
    let point = |r: usize| {
        let hi = p.points[r];
        let lo = if p.residual_rows > 0 {
            p.points[p.residual_rows as usize + r]
        } else {
            [0.0; 4]
        };
        DVec3::from_array([0, 1, 2].map(|k| hi[k] as f64 + lo[k] as f64))
    };
    located
        .par_iter()
        .map(|&(k, u, v, j)| {
            let rows = &p.patch_points[k as usize];
            let cv: [DVec3; 20] = std::array::from_fn(|i| point(rows[i] as usize));
            let e = crate::geom::gregory::eval_generic(&cv, u, v, true, true);
            let du = e.su * j[0][0] + e.sv * j[1][0];
            let dv = e.su * j[0][1] + e.sv * j[1][1];
            // The map is affine: second derivatives are Jᵀ·H·J.
            let [huu, huv, hvv] = e.second;
            let (a, b, c, d) = (j[0][0], j[0][1], j[1][0], j[1][1]);
            let duu = huu * (a * a) + huv * (2.0 * a * c) + hvv * (c * c);
            let duv = huu * (a * b) + huv * (a * d + c * b) + hvv * (c * d);
            let dvv = huu * (b * b) + huv * (2.0 * b * d) + hvv * (d * d);
            [e.p, du, dv, duu, duv, dvv].map(|x| x.as_vec3().to_array())
        })
        .collect()
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

/// Per-level tables: what depends on the sample's (u, v) alone, computed once per level instead of once
/// per sample and patch, in the shader's scalar operation order (so the same bits): per sample the
/// Bernstein weights, the rational points' weights and the exact-derivative weights; per column the u
/// weights; per edge sample m = 0…L the edge weights bern3(m/L).
struct LevelTable {
    level: u32,
    /// Samples in output order (rows of u inner).
    samples: Vec<SampleWeights>,
    /// Per column i: bern3(i/L) values and derivatives.
    columns: Vec<([f32; 4], [f32; 4])>,
    /// Edge weights per sample m = 0…L (padded by a lane group): bern3(m/L).b, and bern3((L−m)/L).b for
    /// edges against their canonical direction.
    edge_fwd: [Vec<f32>; 4],
    edge_rev: [Vec<f32>; 4],
}

/// The weights of one grid sample.
#[derive(Clone, Copy, Default)]
struct SampleWeights {
    u: f32,
    v: f32,
    /// The sample's column i (its u = i/L).
    column: usize,
    /// bern3(u) values and derivatives (entries 1 and 2: columns 0 and 3 are in the column values).
    bu: [f32; 4],
    du: [f32; 4],
    /// bern3(v) values and derivatives.
    bv: [f32; 4],
    dv: [f32; 4],
    /// The rational interior points Q11, Q21, Q12, Q22.
    rational: [RationalWeights; 4],
    /// The exact-derivative weights B_i(u)·B_j(v) of Q11, Q21, Q12, Q22.
    exact: [f32; 4],
}

/// `gregory_rational`'s weights at one sample: Q = (pa·a + pb·b)·inv, Q_u = (pa − pb)·fu,
/// Q_v = (pa − pb)·fv; at a corner (a + b < 1e-6) Q = pa and both derivatives 0.
#[derive(Clone, Copy, Default)]
struct RationalWeights {
    a: f32,
    b: f32,
    inv: f32,
    fu: f32,
    fv: f32,
    corner: bool,
}

impl RationalWeights {
    /// With constant signs ∂a/∂u = au, ∂b/∂v = bv, in the shader's order: d = a + b, inv = 1/d,
    /// fu = (au·b)·inv², fv = −(a·bv)·inv².
    fn new(a: f32, b: f32, au: f32, bv: f32) -> Self {
        let d = a + b;
        let inv = 1.0 / d;
        let inv2 = inv * inv;
        RationalWeights {
            a,
            b,
            inv,
            fu: au * b * inv2,
            fv: -(a * bv) * inv2,
            corner: d < CORNER_EPS,
        }
    }
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
    /// Room for one batch's column values (see [`eval_batch`]).
    fn column_scratch(&self) -> Vec<Columns> {
        vec![[[0.0; LANES]; COL_VALUES]; self.columns.len()]
    }

    fn new(level: u32) -> Self {
        let n = (level + 1) as usize;
        let param = |k: usize| (k as f32 / level as f32).clamp(0.0, 1.0);
        let mut t = LevelTable {
            level,
            samples: Vec::with_capacity(n * n),
            columns: (0..n).map(|i| bern3(param(i))).collect(),
            edge_fwd: std::array::from_fn(|_| vec![0.0; n + LANES]),
            edge_rev: std::array::from_fn(|_| vec![0.0; n + LANES]),
        };
        for m in 0..n {
            let fwd = bern3(m as f32 / level as f32).0;
            let rev = bern3((level as usize - m) as f32 / level as f32).0;
            for k in 0..4 {
                t.edge_fwd[k][m] = fwd[k];
                t.edge_rev[k][m] = rev[k];
            }
        }
        for s in 0..n * n {
            let (i, j) = (s % n, s / n);
            let (u, v) = (param(i), param(j));
            let (uu, vv) = (1.0 - u, 1.0 - v);
            let (bu, du) = bern3(u);
            let (bv, dv) = bern3(v);
            t.samples.push(SampleWeights {
                u,
                v,
                column: i,
                bu,
                du,
                bv,
                dv,
                rational: [
                    RationalWeights::new(u, v, 1.0, 1.0),
                    RationalWeights::new(uu, v, -1.0, 1.0),
                    RationalWeights::new(u, vv, 1.0, -1.0),
                    RationalWeights::new(uu, vv, -1.0, -1.0),
                ],
                exact: [bu[1] * bv[1], bu[2] * bv[1], bu[1] * bv[2], bu[2] * bv[2]],
            });
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
    let avx2 = simd == HostSimd::Auto && has_avx2();
    par_tasks(out, table.samples.len(), |first, chunk| {
        if avx2 {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: has_avx2() checked that this CPU executes AVX2 instructions.
            unsafe {
                eval_task_avx2(patches, &table, canonical, first, chunk)
            }
        } else {
            eval_task::<F>(patches, &table, canonical, first, chunk)
        }
    });
    Ok(())
}

/// Runs `task(first patch, its items)` over `out` (`per_patch` items per patch, patch-major) on every core,
/// in tasks of about 4,096 items in whole batches of LANES patches: enough to hide the task overhead,
/// enough tasks to balance the cores.
fn par_tasks<T: Send>(out: &mut [T], per_patch: usize, task: impl Fn(usize, &mut [T]) + Sync) {
    let patches_per_task = (4096 / per_patch).max(1).next_multiple_of(LANES);
    out.par_chunks_mut(per_patch * patches_per_task)
        .enumerate()
        .for_each(|(k, chunk)| task(k * patches_per_task, chunk));
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

fn check_level(level: u32) -> Result<()> {
    if !(1..=MAX_LEVEL).contains(&level) {
        return Err(Error::Invalid(format!(
            "tessellation level {level} is outside 1…{MAX_LEVEL}"
        )));
    }
    Ok(())
}

fn check(p: &HostPatches, level: u32, out_len: usize) -> Result<()> {
    check_level(level)?;
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
    eval_task::<Avx2>(p, t, canonical, first, out)
}

/// The patches `first..` whose vertices `out` holds, LANES at a time, in lanes `L`.
#[inline(always)]
fn eval_task<L: Lanes>(
    p: &HostPatches,
    t: &LevelTable,
    canonical: bool,
    first: usize,
    out: &mut [HostVertex],
) {
    let per_patch = ((t.level + 1) * (t.level + 1)) as usize;
    let mut cols = t.column_scratch();
    for (k, grids) in out.chunks_mut(LANES * per_patch).enumerate() {
        let batch = first + k * LANES;
        for next in p.patch_points.iter().skip(batch + LANES).take(LANES) {
            prefetch_points(p, next);
        }
        eval_batch::<L>(p, t, canonical, batch, grids, &mut cols);
    }
}

/// Asks for the next patch's point rows (and residuals) while this one computes: rows are scattered over
/// the points buffer, and their misses otherwise stall the patch set-up.
#[inline(always)]
fn prefetch_points(p: &HostPatches, rows: &[u32; 20]) {
    #[cfg(target_arch = "x86_64")]
    for &r in rows {
        let mut at = [r as usize, (p.residual_rows + r) as usize];
        if p.residual_rows == 0 {
            at[1] = at[0];
        }
        for i in at {
            if let Some(q) = p.points.get(i) {
                // SAFETY: a prefetch is a hint that never faults; `q` is a live element of the slice.
                unsafe {
                    std::arch::x86_64::_mm_prefetch(
                        q.as_ptr() as *const i8,
                        std::arch::x86_64::_MM_HINT_T0,
                    )
                }
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, rows);
}

// ---- lane arithmetic: explicit AVX2, or element-wise loops over [f32; LANES] left to LLVM ----

/// The lane arithmetic the kernel is written in: `Avx2` (what runs on AVX2 CPUs), [`F`] (element-wise
/// loops: the baseline) and [`Counted`] (the values of `F`, each arithmetic operation counted: the bench's
/// operation counts come from this code, not from an estimate).
trait Lanes: Copy {
    fn splat(x: f32) -> Self;
    fn load(v: &[f32]) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    fn get(&self, k: usize) -> f32;
    fn to_array(self) -> F;
    fn from_array(a: F) -> Self;
    /// The results the following lane operations stand for (the valid lanes: patches of a batch, or
    /// samples along an edge), for counting.
    #[inline(always)]
    fn weigh(_samples: usize) {}
    /// [`pow2_scale`] (exponent arithmetic: no flops).
    #[inline(always)]
    fn pow2_scale(a: P3<Self>, b: P3<Self>) -> Self {
        pow2_scale(a, b)
    }
    /// The points and residuals of the patches whose rows are `rows` (residuals 0 without them),
    /// transposed: coordinate c of point k of lane l into `world[3k + c][l]`, `lo[3k + c][l]`.
    #[inline(always)]
    fn gather(p: &HostPatches, rows: &[&[u32; 20]; LANES], world: &mut Net, lo: &mut Net) {
        for l in 0..LANES {
            for k in 0..20 {
                let q = p.points[rows[l][k] as usize];
                let r = if p.residual_rows > 0 {
                    p.points[(p.residual_rows + rows[l][k]) as usize]
                } else {
                    [0.0; 4]
                };
                for c in 0..3 {
                    world[3 * k + c][l] = q[c];
                    lo[3 * k + c][l] = r[c];
                }
            }
        }
    }
    /// The normal test, bit l for lane l: `len > limit` and `len` finite (a comparison: no flops).
    #[inline(always)]
    fn normal_ok(len: Self, limit: Self) -> u32 {
        let (lens, limits) = (len.to_array(), limit.to_array());
        let mut ok = 0;
        for l in 0..LANES {
            ok |= ((lens[l] > limits[l] && lens[l].abs() < f32::INFINITY) as u32) << l;
        }
        ok
    }
    /// Writes a full lane group of vertices (positions `p`, normals `n`), lane l into
    /// `out[at + l·stride]`, if these lanes have a faster way than lane by lane; false if not (nothing
    /// written).
    #[inline(always)]
    fn store_group(
        _out: &mut [HostVertex],
        _at: usize,
        _stride: usize,
        _p: P3<Self>,
        _n: P3<Self>,
    ) -> bool {
        false
    }
}

macro_rules! lanewise {
    ($a:ident, $b:ident, $op:tt) => {{
        let mut r = [0.0; LANES];
        for k in 0..LANES {
            r[k] = $a[k] $op $b[k];
        }
        r
    }};
}

impl Lanes for F {
    #[inline(always)]
    fn splat(x: f32) -> F {
        [x; LANES]
    }
    #[inline(always)]
    fn load(v: &[f32]) -> F {
        v[..LANES].try_into().expect("padded table")
    }
    #[inline(always)]
    fn add(self, o: F) -> F {
        lanewise!(self, o, +)
    }
    #[inline(always)]
    fn sub(self, o: F) -> F {
        lanewise!(self, o, -)
    }
    #[inline(always)]
    fn mul(self, o: F) -> F {
        lanewise!(self, o, *)
    }
    #[inline(always)]
    fn div(self, o: F) -> F {
        lanewise!(self, o, /)
    }
    // Loops, not `array::map`: LLVM leaves `map`'s closure out of line, compiled without AVX2.
    #[inline(always)]
    fn sqrt(self) -> F {
        let mut r = [0.0; LANES];
        for k in 0..LANES {
            r[k] = self[k].sqrt();
        }
        r
    }
    #[inline(always)]
    fn get(&self, k: usize) -> f32 {
        self[k]
    }
    #[inline(always)]
    fn to_array(self) -> F {
        self
    }
    #[inline(always)]
    fn from_array(a: F) -> F {
        a
    }
}

/// AVX2 lanes: one `__m256` per lane group, the arithmetic as explicit instructions (the element-wise loops
/// of [`F`] are left to LLVM's vectorizers, which may vectorize across a point's x, y, z instead of across
/// lanes). The same IEEE operations, so the same bits.
///
/// Only [`eval_task_avx2`]'s call tree makes or uses these lanes: every method executes AVX2
/// instructions, which [`has_avx2`] checked before that call.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx2(std::arch::x86_64::__m256);

/// One `Lanes` method of two operands as one intrinsic.
#[cfg(target_arch = "x86_64")]
macro_rules! avx2_binary {
    ($name:ident, $intrinsic:ident) => {
        #[inline(always)]
        fn $name(self, o: Self) -> Self {
            // SAFETY: AVX2 where these lanes exist (see `Avx2`).
            unsafe { Avx2(std::arch::x86_64::$intrinsic(self.0, o.0)) }
        }
    };
}

// The intrinsics need AVX/AVX2, which the CPU has where these lanes exist (see `Avx2`); loads and stores
// go through `LANES`-long slices or arrays.
#[cfg(target_arch = "x86_64")]
impl Lanes for Avx2 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe { Avx2(std::arch::x86_64::_mm256_set1_ps(x)) }
    }
    #[inline(always)]
    fn load(v: &[f32]) -> Self {
        let v = &v[..LANES];
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe { Avx2(std::arch::x86_64::_mm256_loadu_ps(v.as_ptr())) }
    }
    avx2_binary!(add, _mm256_add_ps);
    avx2_binary!(sub, _mm256_sub_ps);
    avx2_binary!(mul, _mm256_mul_ps);
    avx2_binary!(div, _mm256_div_ps);
    #[inline(always)]
    fn sqrt(self) -> Self {
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe { Avx2(std::arch::x86_64::_mm256_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn get(&self, k: usize) -> f32 {
        self.to_array()[k]
    }
    #[inline(always)]
    fn to_array(self) -> F {
        let mut a = [0.0; LANES];
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe { std::arch::x86_64::_mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn from_array(a: F) -> Self {
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe { Avx2(std::arch::x86_64::_mm256_loadu_ps(a.as_ptr())) }
    }
    /// [`pow2_scale`] in integer lanes: max |component| (the maxima agree with `f32::max` for the
    /// finite vectors whose scale is used: a non-finite S_u or S_v fails the normal test either way).
    #[inline(always)]
    fn pow2_scale(a: P3<Self>, b: P3<Self>) -> Self {
        use std::arch::x86_64::*;
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe {
            let abs = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
            macro_rules! m {
                ($x:expr) => {
                    _mm256_and_ps($x.0, abs)
                };
            }
            let mx = _mm256_max_ps(_mm256_max_ps(m!(a.x), m!(a.y)), m!(a.z));
            let mx = _mm256_max_ps(mx, _mm256_max_ps(_mm256_max_ps(m!(b.x), m!(b.y)), m!(b.z)));
            let exp = _mm256_and_si256(
                _mm256_srli_epi32::<23>(_mm256_castps_si256(mx)),
                _mm256_set1_epi32(0xff),
            );
            let scaled = _mm256_slli_epi32::<23>(_mm256_sub_epi32(_mm256_set1_epi32(253), exp));
            // exp ≠ 0 and exp < 253 (which also excludes 255).
            let normal = _mm256_and_si256(
                _mm256_cmpgt_epi32(exp, _mm256_setzero_si256()),
                _mm256_cmpgt_epi32(_mm256_set1_epi32(253), exp),
            );
            Avx2(_mm256_blendv_ps(
                _mm256_set1_ps(1.0),
                _mm256_castsi256_ps(scaled),
                _mm256_castsi256_ps(normal),
            ))
        }
    }
    /// Two 4×4 transposes in 256-bit registers per point: lanes l and l + 4 loaded as the halves of one
    /// register, then unpacks and shuffles (18 instructions instead of 48 scalar moves).
    #[inline(always)]
    fn gather(p: &HostPatches, rows: &[&[u32; 20]; LANES], world: &mut Net, lo: &mut Net) {
        use std::arch::x86_64::*;
        let (base, reach) = (p.points, p.residual_rows as usize);
        // Macros, not closures: a closure left out of line would be compiled without AVX2.
        macro_rules! row_of {
            ($l:expr, $k:expr, $offset:expr) => {
                base[rows[$l][$k] as usize + $offset].as_ptr()
            };
        }
        macro_rules! pair {
            ($l:expr, $k:expr, $offset:expr) => {
                _mm256_insertf128_ps::<1>(
                    _mm256_castps128_ps256(_mm_loadu_ps(row_of!($l, $k, $offset))),
                    _mm_loadu_ps(row_of!($l + 4, $k, $offset)),
                )
            };
        }
        macro_rules! transpose {
            ($k:expr, $offset:expr, $to:expr) => {{
                // SAFETY: AVX2 (see `Avx2`); 16-byte loads of live [f32; 4] rows, 32-byte stores into
                // live [f32; 8] rows.
                unsafe {
                    let (v0, v1) = (pair!(0, $k, $offset), pair!(1, $k, $offset));
                    let (v2, v3) = (pair!(2, $k, $offset), pair!(3, $k, $offset));
                    let (xy01, xy23) = (_mm256_unpacklo_ps(v0, v1), _mm256_unpacklo_ps(v2, v3));
                    let (zw01, zw23) = (_mm256_unpackhi_ps(v0, v1), _mm256_unpackhi_ps(v2, v3));
                    let to: &mut Net = $to;
                    _mm256_storeu_ps(to[3 * $k].as_mut_ptr(), _mm256_shuffle_ps::<0x44>(xy01, xy23));
                    _mm256_storeu_ps(
                        to[3 * $k + 1].as_mut_ptr(),
                        _mm256_shuffle_ps::<0xEE>(xy01, xy23),
                    );
                    _mm256_storeu_ps(
                        to[3 * $k + 2].as_mut_ptr(),
                        _mm256_shuffle_ps::<0x44>(zw01, zw23),
                    );
                }
            }};
        }
        for k in 0..20 {
            transpose!(k, 0, world);
            if reach > 0 {
                transpose!(k, reach, lo);
            }
        }
    }
    #[inline(always)]
    fn normal_ok(len: Self, limit: Self) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: AVX2 where these lanes exist (see `Avx2`).
        unsafe {
            let abs = _mm256_and_ps(len.0, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
            let ok = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(len.0, limit.0),
                _mm256_cmp_ps::<_CMP_LT_OQ>(abs, _mm256_set1_ps(f32::INFINITY)),
            );
            _mm256_movemask_ps(ok) as u32
        }
    }
    #[inline(always)]
    fn store_group(
        out: &mut [HostVertex],
        at: usize,
        stride: usize,
        p: P3<Self>,
        n: P3<Self>,
    ) -> bool {
        // SAFETY: AVX2 where these lanes exist (see `Avx2`); store8_avx2 checks the indices.
        unsafe {
            store8_avx2(
                out,
                at,
                stride,
                [p.x.0, p.y.0, p.z.0],
                [n.x.0, n.y.0, n.z.0],
            )
        };
        true
    }
}

/// Operations of one kernel run, each lane operation weighted by the samples it computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCounts {
    /// Additions and subtractions.
    pub add: u64,
    /// Multiplications.
    pub mul: u64,
    /// Divisions.
    pub div: u64,
    /// Square roots.
    pub sqrt: u64,
}

impl OpCounts {
    /// add + mul + div + sqrt: the flops of the floor (a fused multiply-add would be 2).
    pub fn flops(&self) -> u64 {
        self.add + self.mul + self.div + self.sqrt
    }
}

thread_local! {
    /// (the samples each lane operation stands for, the counts so far) of the counting run on this thread.
    static COUNTER: std::cell::Cell<(u64, OpCounts)> = const {
        std::cell::Cell::new((0, OpCounts { add: 0, mul: 0, div: 0, sqrt: 0 }))
    };
}

/// Lanes that count: the arithmetic of [`F`], plus a tally in [`COUNTER`].
#[derive(Clone, Copy)]
struct Counted(F);

impl Counted {
    fn tally(f: impl Fn(&mut OpCounts, u64)) {
        COUNTER.with(|c| {
            let (w, mut n) = c.get();
            f(&mut n, w);
            c.set((w, n));
        })
    }
}

impl Lanes for Counted {
    fn splat(x: f32) -> Self {
        Counted(F::splat(x))
    }
    fn load(v: &[f32]) -> Self {
        Counted(F::load(v))
    }
    fn add(self, o: Self) -> Self {
        Self::tally(|n, w| n.add += w);
        Counted(self.0.add(o.0))
    }
    fn sub(self, o: Self) -> Self {
        Self::tally(|n, w| n.add += w);
        Counted(self.0.sub(o.0))
    }
    fn mul(self, o: Self) -> Self {
        Self::tally(|n, w| n.mul += w);
        Counted(self.0.mul(o.0))
    }
    fn div(self, o: Self) -> Self {
        Self::tally(|n, w| n.div += w);
        Counted(self.0.div(o.0))
    }
    fn sqrt(self) -> Self {
        Self::tally(|n, w| n.sqrt += w);
        Counted(self.0.sqrt())
    }
    fn get(&self, k: usize) -> f32 {
        self.0[k]
    }
    fn to_array(self) -> F {
        self.0
    }
    fn from_array(a: F) -> Self {
        Counted(a)
    }
    fn weigh(samples: usize) {
        COUNTER.with(|c| c.set((samples as u64, c.get().1)));
    }
}

/// A point per lane.
#[derive(Clone, Copy)]
struct P3<L> {
    x: L,
    y: L,
    z: L,
}

impl<L: Lanes> P3<L> {
    #[inline(always)]
    fn splat(p: [f32; 3]) -> Self {
        P3 {
            x: L::splat(p[0]),
            y: L::splat(p[1]),
            z: L::splat(p[2]),
        }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        P3 {
            x: self.x.add(o.x),
            y: self.y.add(o.y),
            z: self.z.add(o.z),
        }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        P3 {
            x: self.x.sub(o.x),
            y: self.y.sub(o.y),
            z: self.z.sub(o.z),
        }
    }
    #[inline(always)]
    fn scale(self, s: L) -> Self {
        P3 {
            x: self.x.mul(s),
            y: self.y.mul(s),
            z: self.z.mul(s),
        }
    }
    /// Point `k` of lane arrays holding coordinate c of point k at `[3k + c]` (a [`Net`] or
    /// [`Columns`]).
    #[inline(always)]
    fn at<const N: usize>(rows: &[F; N], k: usize) -> Self {
        P3 {
            x: L::from_array(rows[3 * k]),
            y: L::from_array(rows[3 * k + 1]),
            z: L::from_array(rows[3 * k + 2]),
        }
    }
    #[inline(always)]
    fn lane(&self, k: usize) -> Vec3 {
        Vec3::new(self.x.get(k), self.y.get(k), self.z.get(k))
    }
    /// `cross` as GLSL and glam compute it.
    #[inline(always)]
    fn cross(self, o: Self) -> Self {
        P3 {
            x: self.y.mul(o.z).sub(o.y.mul(self.z)),
            y: self.z.mul(o.x).sub(o.z.mul(self.x)),
            z: self.x.mul(o.y).sub(o.x.mul(self.y)),
        }
    }
    /// `length`: sqrt((x·x + y·y) + z·z).
    #[inline(always)]
    fn length(self) -> L {
        self.x
            .mul(self.x)
            .add(self.y.mul(self.y))
            .add(self.z.mul(self.z))
            .sqrt()
    }
}

/// `gregory_row`: ((a·w0 + b·w1) + c·w2) + d·w3.
#[inline(always)]
fn row<L: Lanes>(a: P3<L>, b: P3<L>, c: P3<L>, d: P3<L>, w: &[L; 4]) -> P3<L> {
    a.scale(w[0])
        .add(b.scale(w[1]))
        .add(c.scale(w[2]))
        .add(d.scale(w[3]))
}

/// `gregory_rational` at one sample for every lane: (Q, Q_u, Q_v) from the sample's weights.
#[inline(always)]
fn rational<L: Lanes>(pa: P3<L>, pb: P3<L>, w: &RationalWeights) -> (P3<L>, P3<L>, P3<L>) {
    if w.corner {
        let zero = P3::splat([0.0; 3]);
        return (pa, zero, zero);
    }
    let q = pa
        .scale(L::splat(w.a))
        .add(pb.scale(L::splat(w.b)))
        .scale(L::splat(w.inv));
    let diff = pa.sub(pb);
    (q, diff.scale(L::splat(w.fu)), diff.scale(L::splat(w.fv)))
}

/// `pow2_rescale` as geom::gregory's `rescaled`: both vectors times 2^−e, the largest component's
/// exponent brought to [½, 1); zero, subnormal, non-finite and near-overflow maxima are left alone (×1).
/// (Exponent arithmetic, no flops: exact.)
#[inline(always)]
fn pow2_scale<L: Lanes>(a: P3<L>, b: P3<L>) -> L {
    // Plain arrays and a select, not per-lane stores: LLVM keeps this in vector registers (a vector load
    // of lanes stored one by one stalls on store forwarding).
    let (ax, ay, az) = (a.x.to_array(), a.y.to_array(), a.z.to_array());
    let (bx, by, bz) = (b.x.to_array(), b.y.to_array(), b.z.to_array());
    let mut k = [0.0f32; LANES];
    for l in 0..LANES {
        let m = ax[l]
            .abs()
            .max(ay[l].abs())
            .max(az[l].abs())
            .max(bx[l].abs().max(by[l].abs()).max(bz[l].abs()));
        let exp = (m.to_bits() >> 23) & 0xff;
        // m = f·2^e, f in [½, 1): e = exp − 126; 2^−e has the biased exponent 253 − exp (≥ 1 to be normal).
        let scaled = f32::from_bits(253u32.wrapping_sub(exp) << 23);
        k[l] = if exp != 0 && exp != 255 && exp < 253 {
            scaled
        } else {
            1.0
        };
    }
    L::from_array(k)
}

/// Quantities per column of a patch (see [`eval_batch`]), each a point: rows 0 and 3 of the net contracted
/// with bern3(u).b and .d, and columns 0 and 3 of rows 1 and 2 times b0, b3, d0, d3.
const COL_QUANTITIES: usize = 12;
/// Floats per column of a patch's column values.
const COL_VALUES: usize = 3 * COL_QUANTITIES;

/// Writes a full lane group of vertices: positions `p`, normals `n` (one array per coordinate), lane l
/// into `out[at + l·stride]`, with the w components 1 and 0: an 8×8 transpose in registers and eight
/// 32-byte stores instead of 64 lane extracts.
///
/// # Safety
/// The CPU must execute AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store8_avx2(
    out: &mut [HostVertex],
    at: usize,
    stride: usize,
    p: [std::arch::x86_64::__m256; 3],
    n: [std::arch::x86_64::__m256; 3],
) {
    assert!(
        at + (LANES - 1) * stride < out.len(),
        "a lane group past the output"
    );
    use std::arch::x86_64::*;
    let [px, py, pz] = p;
    let [nx, ny, nz] = n;
    let (one, zero) = (_mm256_set1_ps(1.0), _mm256_setzero_ps());
    // Pairs interleaved: (x0 y0 x1 y1 | x4 y4 x5 y5), (x2 y2 x3 y3 | x6 y6 x7 y7), …
    let (pxy_lo, pxy_hi) = (_mm256_unpacklo_ps(px, py), _mm256_unpackhi_ps(px, py));
    let (pzw_lo, pzw_hi) = (_mm256_unpacklo_ps(pz, one), _mm256_unpackhi_ps(pz, one));
    let (nxy_lo, nxy_hi) = (_mm256_unpacklo_ps(nx, ny), _mm256_unpackhi_ps(nx, ny));
    let (nzw_lo, nzw_hi) = (_mm256_unpacklo_ps(nz, zero), _mm256_unpackhi_ps(nz, zero));
    // Four-float halves: (x0 y0 z0 1 | x4 y4 z4 1) for vertices 0 and 4, and so on.
    let p04 = _mm256_shuffle_ps::<0x44>(pxy_lo, pzw_lo);
    let p15 = _mm256_shuffle_ps::<0xEE>(pxy_lo, pzw_lo);
    let p26 = _mm256_shuffle_ps::<0x44>(pxy_hi, pzw_hi);
    let p37 = _mm256_shuffle_ps::<0xEE>(pxy_hi, pzw_hi);
    let n04 = _mm256_shuffle_ps::<0x44>(nxy_lo, nzw_lo);
    let n15 = _mm256_shuffle_ps::<0xEE>(nxy_lo, nzw_lo);
    let n26 = _mm256_shuffle_ps::<0x44>(nxy_hi, nzw_hi);
    let n37 = _mm256_shuffle_ps::<0xEE>(nxy_hi, nzw_hi);
    let rows = [
        _mm256_permute2f128_ps::<0x20>(p04, n04),
        _mm256_permute2f128_ps::<0x20>(p15, n15),
        _mm256_permute2f128_ps::<0x20>(p26, n26),
        _mm256_permute2f128_ps::<0x20>(p37, n37),
        _mm256_permute2f128_ps::<0x31>(p04, n04),
        _mm256_permute2f128_ps::<0x31>(p15, n15),
        _mm256_permute2f128_ps::<0x31>(p26, n26),
        _mm256_permute2f128_ps::<0x31>(p37, n37),
    ];
    let base = out.as_mut_ptr();
    for (l, r) in rows.into_iter().enumerate() {
        // SAFETY: at + l·stride < out.len() (the assert above): a live, exclusively borrowed vertex of
        // 32 writable bytes.
        unsafe { _mm256_storeu_ps(base.add(at + l * stride) as *mut f32, r) };
    }
}

/// Patch-local points of a batch: coordinate c of point k at `[3k + c]`, lane l = patch l.
type Net = [F; 60];
/// Column values of a batch at one column (see [`COL_QUANTITIES`]), lane l = patch l.
type Columns = [F; COL_VALUES];

/// What a sample's contraction yields for every lane: the position, S_u, S_v (before the rescale) and
/// the rational points (for the fallback normal).
struct Sample<L> {
    pos: P3<L>,
    su: P3<L>,
    sv: P3<L>,
    q11: P3<L>,
    q21: P3<L>,
    q12: P3<L>,
    q22: P3<L>,
}

/// The contraction at one sample, each lane a patch: the shader's `gregory_row(r0, r1, r2, r3, bv)` with
/// each row `gregory_row(c0, c1, c2, c3, bu)`, summed in the same order (so the same bits), row by row
/// (a few points live instead of sixteen). Rows 0 and 3 and the plain-point terms of rows 1 and 2 come
/// from the column values; interior cells Q11 (1,1), Q21 (2,1) in row 1, Q12 (1,2), Q22 (2,2) in row 2,
/// so rows 1 and 2 are ((c0·b0 + Q·b1) + Q·b2) + c3·b3 with c0·b0 and c3·b3 from the columns.
#[inline(always)]
fn contract<L: Lanes>(net: &Net, cols: &Columns, w: &SampleWeights, origin: P3<L>) -> Sample<L> {
    macro_rules! cv {
        ($k:expr) => {
            P3::<L>::at(net, $k)
        };
    }
    macro_rules! col {
        ($q:expr) => {
            P3::<L>::at(cols, $q)
        };
    }
    let s = L::splat;
    let (bu1, bu2, du1, du2) = (s(w.bu[1]), s(w.bu[2]), s(w.du[1]), s(w.du[2]));
    let r0 = col!(0);
    let mut pos = r0.scale(s(w.bv[0]));
    let mut su = col!(1).scale(s(w.bv[0]));
    let mut sv = r0.scale(s(w.dv[0]));
    let (q11, u11, v11) = rational(cv!(3), cv!(4), &w.rational[0]);
    let (q21, u21, v21) = rational(cv!(9), cv!(8), &w.rational[1]);
    let r1 = col!(4).add(q11.scale(bu1)).add(q21.scale(bu2)).add(col!(5));
    let d1 = col!(6).add(q11.scale(du1)).add(q21.scale(du2)).add(col!(7));
    pos = pos.add(r1.scale(s(w.bv[1])));
    su = su.add(d1.scale(s(w.bv[1])));
    sv = sv.add(r1.scale(s(w.dv[1])));
    let (q12, u12, v12) = rational(cv!(19), cv!(18), &w.rational[2]);
    let (q22, u22, v22) = rational(cv!(13), cv!(14), &w.rational[3]);
    let r2 = col!(8).add(q12.scale(bu1)).add(q22.scale(bu2)).add(col!(9));
    let d2 = col!(10)
        .add(q12.scale(du1))
        .add(q22.scale(du2))
        .add(col!(11));
    pos = pos.add(r2.scale(s(w.bv[2])));
    su = su.add(d2.scale(s(w.bv[2])));
    sv = sv.add(r2.scale(s(w.dv[2])));
    let r3 = col!(2);
    let pos = pos.add(r3.scale(s(w.bv[3]))).add(origin);
    su = su.add(col!(3).scale(s(w.bv[3])));
    sv = sv.add(r3.scale(s(w.dv[3])));
    // Exact-derivative terms Σ B_i(u) B_j(v) ∂Q_ij, in the shader's order Q11, Q21, Q12, Q22.
    for (qu, qv, e) in [(u11, v11, 0), (u21, v21, 1), (u12, v12, 2), (u22, v22, 3)] {
        let e = s(w.exact[e]);
        su = su.add(qu.scale(e));
        sv = sv.add(qv.scale(e));
    }
    Sample {
        pos,
        su,
        sv,
        q11,
        q21,
        q12,
        q22,
    }
}

/// The normal of lane `l` whose S_u × S_v failed the test: the sample contracted again (the same
/// operations, so the same S_u, S_v and rational points; out of the hot loop, which then keeps none of
/// them) and [`normal_from_net_f32`].
#[cold]
#[inline(never)]
fn fallback_normal(net: &Net, cols: &Columns, w: &SampleWeights, l: usize) -> [f32; 3] {
    let s = contract::<F>(net, cols, w, P3::splat([0.0; 3]));
    let c = |k: usize| Vec3::new(net[3 * k][l], net[3 * k + 1][l], net[3 * k + 2][l]);
    let net = [
        [c(0), c(1), c(7), c(5)],
        [c(2), s.q11.lane(l), s.q21.lane(l), c(6)],
        [c(16), s.q12.lane(l), s.q22.lane(l), c(12)],
        [c(15), c(17), c(11), c(10)],
    ];
    normal_from_net_f32(&net, s.su.lane(l), s.sv.lane(l), w.u, w.v).to_array()
}

/// The world points and residuals of the `valid` patches from `first`, transposed to lanes
/// ([`Lanes::gather`]); empty lanes repeat the last patch.
/// (Out-parameters: returned by value, the two arrays were copied on every batch.)
#[inline(always)]
fn batch_points<L: Lanes>(
    p: &HostPatches,
    first: usize,
    valid: usize,
    world: &mut Net,
    lo: &mut Net,
) {
    let rows: [&[u32; 20]; LANES] =
        std::array::from_fn(|l| &p.patch_points[first + l.min(valid - 1)]);
    L::gather(p, &rows, world, lo);
}

/// A batch of up to LANES patches from `first` (`grids`: their grids, see [`evaluate`]), lane l = patch
/// first + l, every sample of the grid at once for all of them: no lane is padding at any level (but in a
/// task's last batch, whose empty lanes repeat its last patch and are not written), and what depends on
/// (u, v) alone is a splat of the level table's scalar.
#[inline(always)]
fn eval_batch<L: Lanes>(
    p: &HostPatches,
    t: &LevelTable,
    canonical: bool,
    first: usize,
    grids: &mut [HostVertex],
    cols: &mut [Columns],
) {
    let level = t.level as usize;
    let n = level + 1;
    let per_patch = n * n;
    let valid = grids.len() / per_patch;
    L::weigh(valid);
    // World points and residuals transposed to lanes, then the patch-local points
    // (hi_k − hi_0) + (lo_k − lo_0), a lane per patch (the same bits as scalar f32).
    let (mut world, mut lo): (Net, Net) = ([[0.0; LANES]; 60], [[0.0; LANES]; 60]);
    batch_points::<L>(p, first, valid, &mut world, &mut lo);
    let mut net: Net = [[0.0; LANES]; 60];
    for k in 0..60 {
        let (o, l0) = (L::from_array(world[k % 3]), L::from_array(lo[k % 3]));
        net[k] = L::from_array(world[k])
            .sub(o)
            .add(L::from_array(lo[k]).sub(l0))
            .to_array();
    }
    let origin = P3::<L>::at(&world, 0);
    // The u-only terms of the contraction, once per column instead of once per sample: rows 0 and 3 of
    // the net (values and u-derivatives) and the plain-point terms of rows 1 and 2 — the very products
    // and partial sums the per-sample `gregory_row` would compute.
    macro_rules! cv {
        ($k:expr) => {
            P3::<L>::at(&net, $k)
        };
    }
    for (c, (b, d)) in cols.iter_mut().zip(&t.columns) {
        let s = L::splat;
        let (bu, du) = (
            [s(b[0]), s(b[1]), s(b[2]), s(b[3])],
            [s(d[0]), s(d[1]), s(d[2]), s(d[3])],
        );
        // Stored as computed (an array of the twelve points would be moved with memmove).
        macro_rules! put {
            ($q:expr, $v:expr) => {{
                let v: P3<L> = $v;
                c[3 * $q] = v.x.to_array();
                c[3 * $q + 1] = v.y.to_array();
                c[3 * $q + 2] = v.z.to_array();
            }};
        }
        put!(0, row(cv!(0), cv!(1), cv!(7), cv!(5), &bu));
        put!(1, row(cv!(0), cv!(1), cv!(7), cv!(5), &du));
        put!(2, row(cv!(15), cv!(17), cv!(11), cv!(10), &bu));
        put!(3, row(cv!(15), cv!(17), cv!(11), cv!(10), &du));
        put!(4, cv!(2).scale(bu[0]));
        put!(5, cv!(6).scale(bu[3]));
        put!(6, cv!(2).scale(du[0]));
        put!(7, cv!(6).scale(du[3]));
        put!(8, cv!(16).scale(bu[0]));
        put!(9, cv!(12).scale(bu[3]));
        put!(10, cv!(16).scale(du[0]));
        put!(11, cv!(12).scale(du[3]));
    }
    for (at, w) in t.samples.iter().enumerate() {
        let colv = &cols[w.column];
        let Sample { pos, su, sv, .. } = contract::<L>(&net, colv, w, origin);
        // The normal: S_u × S_v after the power-of-two rescale, tested as the shader tests it.
        let k = L::pow2_scale(su, sv);
        let (rsu, rsv) = (su.scale(k), sv.scale(k));
        let nrm = rsu.cross(rsv);
        let ln = nrm.length();
        let scale = rsu.length().add(rsv.length());
        let limit = L::splat(1e-5).mul(scale).mul(scale);
        let unit = P3 {
            x: nrm.x.div(ln),
            y: nrm.y.div(ln),
            z: nrm.z.div(ln),
        };
        let ok = L::normal_ok(ln, limit);
        if valid == LANES
            && ok == (1 << LANES) - 1
            && L::store_group(grids, at, per_patch, pos, unit)
        {
            continue;
        }
        for l in 0..valid {
            let normal = if (ok >> l) & 1 == 1 {
                [unit.x.get(l), unit.y.get(l), unit.z.get(l)]
            } else {
                fallback_normal(&net, colv, w, l)
            };
            grids[l * per_patch + at] = [
                pos.x.get(l),
                pos.y.get(l),
                pos.z.get(l),
                1.0,
                normal[0],
                normal[1],
                normal[2],
                0.0,
            ];
        }
    }
    if canonical {
        for (l, grid) in grids.chunks_exact_mut(per_patch).enumerate() {
            let wpts: [[f32; 3]; 20] = std::array::from_fn(|k| {
                [world[3 * k][l], world[3 * k + 1][l], world[3 * k + 2][l]]
            });
            edge_samples::<L>(&wpts, p.patch_flags[first + l], t, grid);
        }
    }
}

/// Edge samples of one patch: the canonical boundary cubic from the world-space points replaces the
/// position (rows j = 0, L; columns i = 0, L), LANES samples of one edge at a time.
#[inline(always)]
fn edge_samples<L: Lanes>(
    wpts: &[[f32; 3]; 20],
    flags: u32,
    t: &LevelTable,
    out: &mut [HostVertex],
) {
    let level = t.level as usize;
    let n = level + 1;
    const EDGES: [[usize; 4]; 4] = [
        [0, 1, 7, 5],
        [5, 6, 12, 10],
        [15, 17, 11, 10],
        [0, 2, 16, 15],
    ];
    for e in 0..4 {
        let flipped = (flags >> e) & 1 == 1;
        let [ia, ib, ic, id] = EDGES[e];
        let (a, b) = (P3::<L>::splat(wpts[ia]), P3::<L>::splat(wpts[ib]));
        let (c, d) = (P3::<L>::splat(wpts[ic]), P3::<L>::splat(wpts[id]));
        // Edges 0 and 2 take every sample of their row, edges 1 and 3 the inner ones of their column.
        let (first, last) = if e % 2 == 0 {
            (0, level)
        } else {
            (1, level - 1)
        };
        let mut m0 = first;
        while m0 <= last {
            let lanes = LANES.min(last + 1 - m0);
            L::weigh(lanes);
            let (pts, w) = if flipped {
                ([d, c, b, a], &t.edge_rev)
            } else {
                ([a, b, c, d], &t.edge_fwd)
            };
            let w = [
                L::load(&w[0][m0..]),
                L::load(&w[1][m0..]),
                L::load(&w[2][m0..]),
                L::load(&w[3][m0..]),
            ];
            let q = row(pts[0], pts[1], pts[2], pts[3], &w);
            for l in 0..lanes {
                let m = m0 + l;
                let at = match e {
                    0 => m,
                    1 => m * n + level,
                    2 => level * n + m,
                    _ => m * n,
                };
                out[at][..3].copy_from_slice(&[q.x.get(l), q.y.get(l), q.z.get(l)]);
            }
            m0 += LANES;
        }
    }
}

/// Arithmetic of the kernel on one patch at `level`: each lane operation counted once per patch it
/// computes (the empty lanes of a batch are not counted), the per-patch set-up and column values once.
/// The patch's shape does not change the count except through the normal fallback (samples whose
/// S_u × S_v fails the test), which [`operation_counts`] avoids by evaluating a regular patch.
fn count_patch(p: &HostPatches, level: u32, canonical: bool) -> OpCounts {
    let t = LevelTable::new(level);
    let mut out = vec![[0.0f32; 8]; ((level + 1) * (level + 1)) as usize];
    COUNTER.with(|c| c.set((0, OpCounts::default())));
    let mut cols = t.column_scratch();
    eval_batch::<Counted>(p, &t, canonical, 0, &mut out, &mut cols);
    COUNTER.with(|c| c.get().1)
}

/// What the kernel computes per patch at `level`, counted from its code (the same operations as
/// glsl/gregory_eval.comp's per-sample body with what depends on (u, v) alone in a per-level table, the
/// u-only row terms per column and the patch-local points per patch), and the bytes it moves: 20 point rows
/// and their 20 residual rows (16 B each), the 20 row indices and the flags read, (L+1)² vertices of 32 B
/// written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KernelCounts {
    /// Operations per patch.
    pub ops: OpCounts,
    /// Bytes read and written per patch.
    pub bytes: u64,
}

/// The kernel's operation and byte counts per patch at `level` (1…64), canonical edges on, on a regular
/// (bicubic, non-degenerate) patch.
pub fn operation_counts(level: u32) -> Result<KernelCounts> {
    check_level(level)?;
    // A bicubic patch: cv k at its Bézier position in the unit square, a gentle bump in z.
    let grid = [
        (0, 0),
        (1, 0),
        (0, 1),
        (1, 1),
        (1, 1),
        (3, 0),
        (3, 1),
        (2, 0),
        (2, 1),
        (2, 1),
        (3, 3),
        (2, 3),
        (3, 2),
        (2, 2),
        (2, 2),
        (0, 3),
        (0, 2),
        (1, 3),
        (1, 2),
        (1, 2),
    ];
    let points: Vec<[f32; 4]> = grid
        .iter()
        .map(|&(i, j): &(i32, i32)| {
            let (x, y) = (i as f32 / 3.0, j as f32 / 3.0);
            [x, y, 0.1 * (x * (1.0 - x) + y * (1.0 - y)), 1.0]
        })
        .chain(std::iter::repeat_n([0.0; 4], 20))
        .collect();
    let rows: [u32; 20] = std::array::from_fn(|k| k as u32);
    let hp = HostPatches {
        points: &points,
        residual_rows: 20,
        patch_points: std::slice::from_ref(&rows),
        patch_flags: &[0],
    };
    let per_patch = ((level + 1) * (level + 1)) as u64;
    Ok(KernelCounts {
        ops: count_patch(&hp, level, true),
        bytes: 40 * 16 + 20 * 4 + 4 + per_patch * 32,
    })
}
