//! Suite `peak`: the machine's measured floating-point and memory peaks, the denominators of every floor.
//!
//! Invariants: both kernels run on all cores through rayon (lavapipe executes on the same cores), each figure
//! is the best of the repeats (a peak, not a typical value), and the kernels' results are consumed
//! (`black_box`) so the optimiser cannot remove them.
//! - FMA: per thread, 16 independent f32 accumulator lanes × 4 chains updated with `mul_add` (2 flops each);
//!   independent chains hide the FMA latency and the lanes let the compiler vectorise; compiled for AVX2 + FMA
//!   when the CPU has them (runtime check).
//! - Bandwidth: a parallel copy of a 256 MiB buffer (64 MiB in `--quick`), counted as read + write bytes.
use super::{num, BenchConfig, Report, Table};
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Instant;

/// The measured peaks.
#[derive(Clone, Copy, Debug)]
pub struct Peak {
    /// f32 GFLOP/s (FMA = 2 flops), all threads.
    pub gflops: f64,
    /// Copy bandwidth, GB/s (bytes read + written), all threads.
    pub gbytes: f64,
}

impl Peak {
    /// The time floor (ms) of `elements` elements at `flops` and `bytes` per element: the larger of the
    /// compute-bound and the memory-bound time at the measured peaks.
    pub fn floor_ms(&self, elements: f64, flops: f64, bytes: f64) -> f64 {
        let compute = elements * flops / (self.gflops * 1e9);
        let memory = elements * bytes / (self.gbytes * 1e9);
        compute.max(memory) * 1e3
    }

    /// The achieved fractions (%) of the FMA peak and of the bandwidth of a run of `flops` operations and
    /// `bytes` moved in `ms`.
    pub fn percent_of_peaks(&self, flops: f64, bytes: f64, ms: f64) -> (f64, f64) {
        let secs = ms * 1e-3;
        (
            100.0 * flops / secs / (self.gflops * 1e9),
            100.0 * bytes / secs / (self.gbytes * 1e9),
        )
    }
}

/// One thread's FMA loop: `iters` rounds over 4×16 independent accumulators.
#[inline(always)]
fn fma_body(iters: usize, seed: f32) -> f32 {
    let mut acc = [[seed; 16]; 4];
    let (a, b) = (0.999_999_f32, 1e-7_f32);
    for _ in 0..iters {
        for chain in acc.iter_mut() {
            for x in chain.iter_mut() {
                *x = x.mul_add(a, b);
            }
        }
    }
    acc.iter().flatten().sum()
}

/// The same 64 accumulators as 8 AVX registers updated with `vfmadd` (the baseline x86-64 target has no FMA
/// instruction, and LLVM keeps `fma_body` scalar): the figure lavapipe's JIT, which targets the host CPU, could
/// reach.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fma_kernel_avx2(iters: usize, seed: f32) -> f32 {
    use std::arch::x86_64::*;
    let a = _mm256_set1_ps(0.999_999);
    let b = _mm256_set1_ps(1e-7);
    let mut acc = [_mm256_set1_ps(seed); 8];
    for _ in 0..iters {
        for x in acc.iter_mut() {
            *x = _mm256_fmadd_ps(*x, a, b);
        }
    }
    let mut out = [0f32; 8];
    let mut sum = _mm256_setzero_ps();
    for x in acc {
        sum = _mm256_add_ps(sum, x);
    }
    _mm256_storeu_ps(out.as_mut_ptr(), sum);
    out.iter().sum()
}

/// The FMA loop with the best instruction set this CPU has.
fn fma_kernel(iters: usize, seed: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA (checked just above).
        return unsafe { fma_kernel_avx2(iters, seed) };
    }
    fma_body(iters, seed)
}

/// Measured f32 GFLOP/s on all threads (best of `repeats`).
pub fn measure_flops(repeats: usize, iters: usize) -> f64 {
    let threads = rayon::current_num_threads();
    let mut best: f64 = 0.0;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let s: f32 = (0..threads)
            .into_par_iter()
            .map(|i| fma_kernel(black_box(iters), i as f32 * 1e-3))
            .sum();
        black_box(s);
        let secs = t.elapsed().as_secs_f64();
        let flops = threads as f64 * iters as f64 * 64.0 * 2.0;
        best = best.max(flops / secs / 1e9);
    }
    best
}

/// Measured copy bandwidth in GB/s (read + write) on all threads (best of `repeats`).
pub fn measure_bandwidth(repeats: usize, bytes: usize) -> f64 {
    let n = bytes / 8;
    let src: Vec<u64> = (0..n as u64).collect();
    let mut dst = vec![0u64; n];
    let chunk = (n / (rayon::current_num_threads() * 8)).max(4096);
    let mut best: f64 = 0.0;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        dst.par_chunks_mut(chunk)
            .zip(src.par_chunks(chunk))
            .for_each(|(d, s)| d.copy_from_slice(s));
        black_box(&dst);
        let secs = t.elapsed().as_secs_f64();
        best = best.max(2.0 * (n * 8) as f64 / secs / 1e9);
    }
    best
}

/// Runs the suite: measures and adds the peak table.
pub fn run(cfg: &BenchConfig, report: &mut Report) -> anyhow::Result<Peak> {
    let (iters, bytes) = if cfg.quick {
        (2_000_000, 64 << 20)
    } else {
        (20_000_000, 256 << 20)
    };
    let peak = Peak {
        gflops: measure_flops(cfg.repeats, iters),
        gbytes: measure_bandwidth(cfg.repeats, bytes),
    };
    let mut t = Table::new(
        "peak",
        "Machine peak (measured in this run)",
        &format!(
            "All {} rayon threads. FMA: independent f32 multiply-add chains (2 flops per FMA), best of {} runs. \
             Bandwidth: parallel copy of {} MiB, read + write bytes, best of {} runs. These are the \
             denominators of the floors below.",
            rayon::current_num_threads(),
            cfg.repeats,
            bytes >> 20,
            cfg.repeats
        ),
        &["kernel", "measured peak", "unit"],
    );
    t.push(vec![
        "f32 FMA throughput".into(),
        num(peak.gflops),
        "GFLOP/s".into(),
    ]);
    t.push(vec![
        "memory copy bandwidth".into(),
        num(peak.gbytes),
        "GB/s".into(),
    ]);
    report.tables.push(t);
    Ok(peak)
}
