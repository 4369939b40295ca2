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
//! - The kernel is written once, generic over its lane arithmetic (trait `Lanes`): `[f32; 8]` runs it, and
//!   [`operation_counts`] runs the same code on counting lanes, so the bench's flop counts are the code's.
//! - Speed (docs/benchmarks.md, suite `gregory`): nothing on the lane path is a closure or `array::map`
//!   (LLVM may leave those out of line, compiled without the caller's AVX2); a row of the net is contracted
//!   in u and added into the v sums at once (fewer live registers, the same summation order); edge samples
//!   are lane groups along one edge; the next patch's points are prefetched.
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
    /// AVX2 where the CPU has it, else the baseline. (AVX-512VL, tried for its 32 registers, ran the
    /// same 8-lane code 20 % slower on a Zen 4 core.)
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

/// Rows of a [`LevelTable`] group: u, v, then the Bernstein values and derivatives in u and in v.
const U: usize = 0;
const V: usize = 1;
const BU: usize = 2;
const DU: usize = 6;
const BV: usize = 10;
const DV: usize = 14;
const ROWS: usize = 18;

/// Per-level tables, one group of lanes per LANES samples of the (L+1)² grid (the last padded): (u, v), the
/// Bernstein values and derivatives in u and in v, and the edge weights bern3(m/L). The same scalar
/// arithmetic as the shader's per-sample `gregory_bern3`, done once per level instead of once per sample.
/// A group's rows are contiguous (one pointer, 576 B per group) so the lane loop loads them without
/// bounds checks on 18 separate arrays.
struct LevelTable {
    level: u32,
    groups: Vec<[F; ROWS]>,
    /// Edge weights per sample m = 0…L (padded by a lane group): bern3(m/L).b, and bern3((L−m)/L).b for
    /// edges against their canonical direction.
    edge_fwd: [Vec<f32>; 4],
    edge_rev: [Vec<f32>; 4],
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
        let groups = (n * n).div_ceil(LANES);
        let param = |k: usize| (k as f32 / level as f32).clamp(0.0, 1.0);
        let mut t = LevelTable {
            level,
            groups: vec![[[0.0; LANES]; ROWS]; groups],
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
        for s in 0..groups * LANES {
            // Padding lanes repeat the last sample: finite values, never written out.
            let s_in = s.min(n * n - 1);
            let (i, j) = (s_in % n, s_in / n);
            let (u, v) = (param(i), param(j));
            let (bu, du) = bern3(u);
            let (bv, dv) = bern3(v);
            let (g, l) = (&mut t.groups[s / LANES], s % LANES);
            g[U][l] = u;
            g[V][l] = v;
            for k in 0..4 {
                g[BU + k][l] = bu[k];
                g[DU + k][l] = du[k];
                g[BV + k][l] = bv[k];
                g[DV + k][l] = dv[k];
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
        if let Some(next) = p.patch_points.get(first + k + 1) {
            prefetch_points(p, next);
        }
        eval_patch::<F>(p, t, canonical, first + k, grid);
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

// ---- lane arithmetic: element-wise loops over [f32; LANES], which LLVM compiles to vector instructions ----

/// The lane arithmetic the kernel is written in: [`F`] (what runs) and [`Counted`] (the same values, each
/// arithmetic operation counted: the bench's operation counts come from this code, not from an estimate).
trait Lanes: Copy {
    fn splat(x: f32) -> Self;
    fn load(v: &[f32]) -> Self;
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// A sign flip (a GPU folds it into the next operation: not counted).
    fn neg(self) -> Self;
    fn sqrt(self) -> Self;
    fn get(&self, k: usize) -> f32;
    fn set(&mut self, k: usize, x: f32);
    fn to_array(self) -> F;
    fn from_array(a: F) -> Self;
    /// The samples the following lane operations compute (the valid lanes of a group), for counting.
    #[inline(always)]
    fn weigh(_samples: usize) {}
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
    fn neg(self) -> F {
        let mut r = [0.0; LANES];
        for k in 0..LANES {
            r[k] = -self[k];
        }
        r
    }
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
    fn set(&mut self, k: usize, x: f32) {
        self[k] = x;
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
    fn neg(self) -> Self {
        Counted(self.0.neg())
    }
    fn sqrt(self) -> Self {
        Self::tally(|n, w| n.sqrt += w);
        Counted(self.0.sqrt())
    }
    fn get(&self, k: usize) -> f32 {
        self.0[k]
    }
    fn set(&mut self, k: usize, x: f32) {
        self.0[k] = x;
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

/// Lane-wise select: `m[k]` ? a : b.
#[inline(always)]
fn select<L: Lanes>(m: [bool; LANES], a: P3<L>, b: P3<L>) -> P3<L> {
    let mut r = b;
    for k in 0..LANES {
        if m[k] {
            r.x.set(k, a.x.get(k));
            r.y.set(k, a.y.get(k));
            r.z.set(k, a.z.get(k));
        }
    }
    r
}

/// `gregory_row`: ((a·w0 + b·w1) + c·w2) + d·w3.
#[inline(always)]
fn row<L: Lanes>(a: P3<L>, b: P3<L>, c: P3<L>, d: P3<L>, w: &[L; 4]) -> P3<L> {
    a.scale(w[0])
        .add(b.scale(w[1]))
        .add(c.scale(w[2]))
        .add(d.scale(w[3]))
}

/// `gregory_rational` with constant signs (∂a/∂u = au, ∂b/∂v = bv): (Q, Q_u, Q_v).
#[inline(always)]
fn rational<L: Lanes>(pa: P3<L>, pb: P3<L>, a: L, b: L, au: f32, bv: f32) -> (P3<L>, P3<L>, P3<L>) {
    let d = a.add(b);
    let inv = L::splat(1.0).div(d);
    let q = pa.scale(a).add(pb.scale(b)).scale(inv);
    let diff = pa.sub(pb);
    let inv2 = inv.mul(inv);
    let fu = L::splat(au).mul(b).mul(inv2);
    let fv = a.mul(L::splat(bv)).neg().mul(inv2);
    let mut guard = [false; LANES];
    for k in 0..LANES {
        guard[k] = d.get(k) < CORNER_EPS;
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

/// Rows `first..first + 4` of a table group.
#[inline(always)]
fn load4<L: Lanes>(rows: &[F; ROWS], first: usize) -> [L; 4] {
    [
        L::from_array(rows[first]),
        L::from_array(rows[first + 1]),
        L::from_array(rows[first + 2]),
        L::from_array(rows[first + 3]),
    ]
}

/// One patch's grid (see [`evaluate`]).
#[inline(always)]
fn eval_patch<L: Lanes>(
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
    // World points and residuals as flat coordinates (60, padded to whole lane groups), then the
    // patch-local points (hi_k − hi_0) + (lo_k − lo_0), a lane group of coordinates per operation (the same
    // bits as scalar f32). Points are splatted where they are used: a broadcast load costs what a vector
    // load does, and 20 splatted points would be 1.9 KB of stores per patch.
    const COORDS: usize = 60usize.div_ceil(LANES) * LANES;
    let (mut world, mut lo) = ([0.0f32; COORDS], [0.0f32; COORDS]);
    for k in 0..20 {
        let q = p.points[rows[k] as usize];
        world[3 * k..3 * k + 3].copy_from_slice(&q[..3]);
        if p.residual_rows > 0 {
            let r = p.points[(p.residual_rows + rows[k]) as usize];
            lo[3 * k..3 * k + 3].copy_from_slice(&r[..3]);
        }
    }
    let (mut o, mut l0) = ([0.0f32; COORDS], [0.0f32; COORDS]);
    for i in 0..COORDS {
        o[i] = world[i % 3];
        l0[i] = lo[i % 3];
    }
    let mut local = [0.0f32; COORDS];
    for g in (0..60).step_by(LANES) {
        L::weigh(LANES.min(60 - g));
        let d = L::load(&world[g..])
            .sub(L::load(&o[g..]))
            .add(L::load(&lo[g..]).sub(L::load(&l0[g..])));
        local[g..g + LANES].copy_from_slice(&d.to_array());
    }
    // Plain arrays and macros, not closures, on the lane path: a closure that LLVM leaves out of line is
    // compiled without the caller's AVX2.
    let (mut pts, mut wpts) = ([[0.0f32; 3]; 20], [[0.0f32; 3]; 20]);
    for k in 0..20 {
        pts[k] = [local[3 * k], local[3 * k + 1], local[3 * k + 2]];
        wpts[k] = [world[3 * k], world[3 * k + 1], world[3 * k + 2]];
    }
    macro_rules! cv {
        ($k:expr) => {
            P3::<L>::splat(pts[$k])
        };
    }
    let origin = wpts[0];
    let origin3 = P3::splat(origin);
    let one = L::splat(1.0);
    let per_patch = n * n;
    for g in (0..per_patch).step_by(LANES) {
        let lanes = LANES.min(per_patch - g);
        L::weigh(lanes);
        let tab = &t.groups[g / LANES];
        let (u, v) = (L::from_array(tab[U]), L::from_array(tab[V]));
        let (bu, du) = (load4::<L>(tab, BU), load4::<L>(tab, DU));
        let (bv, dv) = (load4::<L>(tab, BV), load4::<L>(tab, DV));
        let (uu, vv) = (one.sub(u), one.sub(v));
        // Row by row of the net: each row contracted in u (values and derivatives) and added at once into
        // the v contractions — the shader's `gregory_row(r0, r1, r2, r3, bv)` summed in the same order, so the
        // same bits, with a few points live instead of all sixteen rows (which spilled to the stack).
        // Interior cells Q11 (1,1), Q21 (2,1) in row 1, Q12 (1,2), Q22 (2,2) in row 2.
        let r0 = row(cv!(0), cv!(1), cv!(7), cv!(5), &bu);
        let d0 = row(cv!(0), cv!(1), cv!(7), cv!(5), &du);
        let mut pos = r0.scale(bv[0]);
        let mut su = d0.scale(bv[0]);
        let mut sv = r0.scale(dv[0]);
        let (q11, u11, v11) = rational(cv!(3), cv!(4), u, v, 1.0, 1.0);
        let (q21, u21, v21) = rational(cv!(9), cv!(8), uu, v, -1.0, 1.0);
        let r1 = row(cv!(2), q11, q21, cv!(6), &bu);
        let d1 = row(cv!(2), q11, q21, cv!(6), &du);
        pos = pos.add(r1.scale(bv[1]));
        su = su.add(d1.scale(bv[1]));
        sv = sv.add(r1.scale(dv[1]));
        let (q12, u12, v12) = rational(cv!(19), cv!(18), u, vv, 1.0, -1.0);
        let (q22, u22, v22) = rational(cv!(13), cv!(14), uu, vv, -1.0, -1.0);
        let r2 = row(cv!(16), q12, q22, cv!(12), &bu);
        let d2 = row(cv!(16), q12, q22, cv!(12), &du);
        pos = pos.add(r2.scale(bv[2]));
        su = su.add(d2.scale(bv[2]));
        sv = sv.add(r2.scale(dv[2]));
        let r3 = row(cv!(15), cv!(17), cv!(11), cv!(10), &bu);
        let d3 = row(cv!(15), cv!(17), cv!(11), cv!(10), &du);
        let pos = pos.add(r3.scale(bv[3])).add(origin3);
        su = su.add(d3.scale(bv[3]));
        sv = sv.add(r3.scale(dv[3]));
        // Exact-derivative terms Σ B_i(u) B_j(v) ∂Q_ij, in the shader's order Q11, Q21, Q12, Q22.
        for (qu, qv, w) in [
            (u11, v11, bu[1].mul(bv[1])),
            (u21, v21, bu[2].mul(bv[1])),
            (u12, v12, bu[1].mul(bv[2])),
            (u22, v22, bu[2].mul(bv[2])),
        ] {
            su = su.add(qu.scale(w));
            sv = sv.add(qv.scale(w));
        }
        // The normal: S_u × S_v after the power-of-two rescale, tested as the shader tests it.
        let k = pow2_scale(su, sv);
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
        for l in 0..lanes {
            let (len, lim) = (ln.get(l), limit.get(l));
            let normal = if len > lim && len.is_finite() {
                [unit.x.get(l), unit.y.get(l), unit.z.get(l)]
            } else {
                let lane = |q: &P3<L>| q.lane(l);
                let c = |k: usize| Vec3::from(pts[k]);
                let net = [
                    [c(0), c(1), c(7), c(5)],
                    [c(2), lane(&q11), lane(&q21), c(6)],
                    [c(16), lane(&q12), lane(&q22), c(12)],
                    [c(15), c(17), c(11), c(10)],
                ];
                normal_from_net_f32(&net, su.lane(l), sv.lane(l), u.get(l), v.get(l)).to_array()
            };
            out[g + l] = [
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
        // Edge samples: the canonical boundary cubic from the world-space points replaces the position
        // (rows j = 0, L; columns i = 0, L), LANES samples of one edge at a time.
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
}

/// Arithmetic of the kernel on one patch at `level`: each lane operation counted once per sample it
/// computes (padding lanes are not counted), the per-patch set-up once. The patch's shape does not change
/// the count except through the normal fallback (samples whose S_u × S_v fails the test), which
/// [`operation_counts`] avoids by evaluating a regular patch.
fn count_patch(p: &HostPatches, level: u32, canonical: bool) -> OpCounts {
    let t = LevelTable::new(level);
    let mut out = vec![[0.0f32; 8]; ((level + 1) * (level + 1)) as usize];
    COUNTER.with(|c| c.set((0, OpCounts::default())));
    eval_patch::<Counted>(p, &t, canonical, 0, &mut out);
    COUNTER.with(|c| c.get().1)
}

/// What the kernel computes per patch at `level`, counted from its code (the same operations as
/// glsl/gregory_eval.comp's per-sample body with the Bernstein weights and the patch-local points hoisted
/// out of the samples: a per-level table and a per-patch set-up), and the bytes it moves: 20 point rows
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
