// OpenSubdiv peer for `gregvox bench` (table `gregory_evaluate_at`): evaluation of a cage's limit surface at
// given (ptex face, u, v) samples — what `gregvox evaluate` / `LimitEvaluator::evaluate` does — with Far's
// patch table built as tests/oracle/osd_gregory.cpp --ptex builds it (the cage's tags, RefineAdaptive(L) with
// L = ⌈largest semi-sharp sharpness⌉, at least 1 with non-quad faces, useInfSharpPatch, Gregory basis end
// caps). Timed (median of REPEATS after one warm-up run), the evaluation only (tables and local points are
// built before, as gregvox's stencils are):
// - `median_s`: one thread, PatchMap::FindPatch + EvaluateBasis + the weighted sums (position, du, dv) in
//   double;
// - `threads_median_s`: the same loop split across every core (OpenMP, static schedule);
// - `omp_median_s`: Osd::OmpEvaluator::EvalPatches in float on every core, the patch coordinates found once
//   before timing (an application re-evaluating fixed samples).
//
// Build: c++ -O2 -fopenmp -std=c++14 -o osd_ptex_bench osd_ptex_bench.cpp -losdCPU  (bench/peers/install.sh)
// Usage: osd_ptex_bench CAGE.obj SAMPLES.bin REPEATS   (SAMPLES.bin: u32 n, then n × f64 (face, u, v))
// Output: one JSON object: {"samples": N, "isolation": L, "patches": P, "median_s": S, "threads": T,
//   "threads_median_s": S, "omp_median_s": S, "position_sum": X}  (X: Σ x + y + z of the double positions,
//   for the caller to compare with its own)
#include <opensubdiv/osd/cpuPatchTable.h>
#include <opensubdiv/osd/ompEvaluator.h>
#include <omp.h>
#include <chrono>
#include <functional>

#include "osd_cage.h"

using namespace OpenSubdiv;


int main(int argc, char **argv) {
    if (argc != 4) { fprintf(stderr, "usage: %s CAGE.obj SAMPLES.bin REPEATS\n", argv[0]); return 2; }
    TaggedCage cage;
    if (!read_tagged_cage(argv[1], cage)) return 1;
    std::ifstream sf(argv[2], std::ios::binary);
    uint32_t n = 0;
    if (!sf.read((char *)&n, 4)) { fprintf(stderr, "%s: cannot read\n", argv[2]); return 1; }
    std::vector<double> fuv((size_t)n * 3);
    if (!sf.read((char *)fuv.data(), fuv.size() * 8)) { fprintf(stderr, "%s: truncated\n", argv[2]); return 1; }
    int repeats = std::max(1, atoi(argv[3]));
    int L = default_isolation(cage);
    GregoryTables t;
    if (!make_tagged_tables(argv[1], cage, L, t)) return 1;
    const int threads = omp_get_max_threads();
    std::vector<double> out((size_t)n * 9);
    int failed = 0;
    auto eval = [&](size_t a, size_t b) {
        int bad = 0;
        for (size_t s = a; s < b; ++s) {
            double *o = &out[s * 9];
            bad += !cpu_sample(t, (int)fuv[3 * s], fuv[3 * s + 1], fuv[3 * s + 2], o, o + 3, o + 6);
        }
        return bad;
    };
    double single = median_seconds(repeats, [&] { failed += eval(0, n); });
    double multi = median_seconds(repeats, [&] {
        int bad = 0;
        const long chunk = 4096;
        const long nchunks = ((long)n + chunk - 1) / chunk;
#pragma omp parallel for schedule(static) reduction(+ : bad)
        for (long c = 0; c < nchunks; ++c) bad += eval((size_t)(c * chunk), std::min((size_t)n, (size_t)((c + 1) * chunk)));
        failed += bad;
    });
    if (failed) { fprintf(stderr, "FindPatch found no patch for %d samples\n", failed); return 1; }
    std::vector<Osd::PatchCoord> coords(n);
    for (size_t s = 0; s < n; ++s) {
        float u = (float)fuv[3 * s + 1], v = (float)fuv[3 * s + 2];
        Far::PatchTable::PatchHandle const *h = t.pmf->FindPatch((int)fuv[3 * s], u, v);
        if (!h) { fprintf(stderr, "FindPatch (float) failed, sample %zu\n", s); return 1; }
        coords[s] = Osd::PatchCoord(*h, u, v);
    }
    Osd::CpuPatchTable *cpt = Osd::CpuPatchTable::Create(t.ptf.get());
    const float *src = &t.ptsf[0].p[0];
    Osd::BufferDescriptor srcDesc(0, 3, 3), dstDesc(0, 3, 3);
    std::vector<float> P((size_t)n * 3), Du((size_t)n * 3), Dv((size_t)n * 3);
    bool ok = true;
    double omp = median_seconds(repeats, [&] {
        ok = ok && Osd::OmpEvaluator::EvalPatches(src, srcDesc, P.data(), dstDesc, Du.data(), dstDesc, Dv.data(),
                                                  dstDesc, (int)n, coords.data(), cpt->GetPatchArrayBuffer(),
                                                  cpt->GetPatchIndexBuffer(), cpt->GetPatchParamBuffer());
    });
    delete cpt;
    if (!ok) { fprintf(stderr, "OmpEvaluator::EvalPatches failed\n"); return 1; }
    double sum = 0;
    for (size_t s = 0; s < n; ++s) sum += out[s * 9] + out[s * 9 + 1] + out[s * 9 + 2];
    printf("{\"samples\": %u, \"isolation\": %d, \"patches\": %d, \"median_s\": %.9g, \"threads\": %d, "
           "\"threads_median_s\": %.9g, \"omp_median_s\": %.9g, \"position_sum\": %.17g}\n",
           n, L, t.pt->GetNumPatchesTotal(), single, threads, multi, omp, sum);
    return 0;
}
