// OpenSubdiv peer for `gregvox bench` (suite `gregory`): CPU evaluation of the same samples gregvox
// evaluates — every face of an all-quad cage, (level+1)^2 samples on the uniform grid u,v = i/level,
// position and both first derivatives — with Far's patch table built exactly as tests/oracle/osd_gregory.cpp
// builds it (isolation 0, CATMARK, VTX_BOUNDARY_EDGE_ONLY, ENDCAP_GREGORY_BASIS), so the patches are the
// ones gregvox's ACC-2 stencils reproduce. Three ways, each timed on its own (median of REPEATS after one
// warm-up run):
// - `median_s`: one thread, PatchMap::FindPatch + PatchTable::EvaluateBasis + the weighted sums in double
//   (the figure kept from the first bench, for continuity);
// - `threads_median_s`: the same loop over faces split across every core (`#pragma omp parallel for`,
//   static schedule; `threads` says how many);
// - `omp_median_s`: Osd::OmpEvaluator::EvalPatches in float (every core), the patch coordinates
//   (FindPatch) computed once before timing, as an application that re-evaluates a fixed sampling does.
// The best of the two all-core figures is the peer users would run.
//
// Timed: the evaluation only, i.e. the same work as gregvox's `gregory_eval` pass; the patch tables and the
// local (Gregory basis) points are built once before timing, like gregvox's stencils and W·cage.
//
// Build: c++ -O2 -fopenmp -std=c++14 -o osd_eval_bench osd_eval_bench.cpp -losdCPU  (bench/peers/install.sh)
// Usage: osd_eval_bench CAGE.obj REPEATS LEVEL...
// Output: one JSON object per level on stdout:
//   {"level": L, "patches": F, "vertices": F*(L+1)^2, "median_s": S, "threads": T, "threads_median_s": S,
//    "omp_median_s": S, "checksum": C, "omp_checksum": C, "max_abs_diff_omp": D}
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/osd/cpuPatchTable.h>
#include <opensubdiv/osd/ompEvaluator.h>
#include <omp.h>
#include <algorithm>
#include <cmath>
#include <functional>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "osd_cage.h"

using namespace OpenSubdiv;



// Every sample of faces [f0, f1): position, du, dv as float, 9 per sample, into out (sample-major).
static bool eval_faces(const GregoryTables &t, int L, int f0, int f1, float *out) {
    size_t k = (size_t)f0 * (L + 1) * (L + 1);
    for (int f = f0; f < f1; ++f)
        for (int j = 0; j <= L; ++j)
            for (int i = 0; i <= L; ++i, ++k) {
                double P[3], Du[3], Dv[3];
                if (!cpu_sample(t, f, (double)i / L, (double)j / L, P, Du, Dv)) return false;
                float *o = &out[k * 9];
                for (int e = 0; e < 3; ++e) { o[e] = (float)P[e]; o[3 + e] = (float)Du[e]; o[6 + e] = (float)Dv[e]; }
            }
    return true;
}

int main(int argc, char **argv) {
    if (argc < 4) { fprintf(stderr, "usage: %s CAGE.obj REPEATS LEVEL...\n", argv[0]); return 2; }
    std::vector<V3> pos;
    std::vector<int> nv, idx;
    if (!read_quad_cage(argv[1], pos, nv, idx)) return 1;
    int repeats = std::max(1, atoi(argv[2]));
    GregoryTables t;
    if (!make_gregory_tables(argv[1], pos, nv, idx, t)) return 1;
    const int nf = (int)nv.size();
    const int threads = omp_get_max_threads();

    // The float path of Osd: the float patch table, its points as the source buffer of x, y, z floats.
    Osd::CpuPatchTable *cpt = Osd::CpuPatchTable::Create(t.ptf.get());
    const float *src = &t.ptsf[0].p[0];
    Osd::BufferDescriptor srcDesc(0, 3, 3), dstDesc(0, 3, 3);

    for (int a = 3; a < argc; ++a) {
        int L = atoi(argv[a]);
        if (L < 1) { fprintf(stderr, "level %s is not positive\n", argv[a]); return 1; }
        size_t n = (size_t)nf * (L + 1) * (L + 1);
        std::vector<float> out(n * 9), out_mt(n * 9);
        bool ok = true;
        double single = median_seconds(repeats, [&] { ok = ok && eval_faces(t, L, 0, nf, out.data()); });
        if (!ok) { fprintf(stderr, "FindPatch failed at level %d\n", L); return 1; }
        double multi = median_seconds(repeats, [&] {
            int failed = 0;
#pragma omp parallel for schedule(static) reduction(+ : failed)
            for (int f = 0; f < nf; ++f) failed += !eval_faces(t, L, f, f + 1, out_mt.data());
            ok = ok && failed == 0;
        });
        if (!ok || out_mt != out) { fprintf(stderr, "the threaded loop differs from the single-thread one\n"); return 1; }

        std::vector<Osd::PatchCoord> coords;
        if (!patch_coords(t, L, coords)) return 1;
        std::vector<float> P(n * 3), Du(n * 3), Dv(n * 3);
        double omp = median_seconds(repeats, [&] {
            ok = ok && Osd::OmpEvaluator::EvalPatches(src, srcDesc, P.data(), dstDesc, Du.data(), dstDesc,
                                                      Dv.data(), dstDesc, (int)n, coords.data(),
                                                      cpt->GetPatchArrayBuffer(), cpt->GetPatchIndexBuffer(),
                                                      cpt->GetPatchParamBuffer());
        });
        if (!ok) { fprintf(stderr, "OmpEvaluator::EvalPatches failed at level %d\n", L); return 1; }
        // The float evaluator computes the same samples (to float rounding): say how far apart they are.
        double diff = 0, checksum = 0, omp_checksum = 0;
        for (size_t q = 0; q < n; ++q)
            for (int e = 0; e < 3; ++e) diff = std::max(diff, (double)std::fabs(P[q * 3 + e] - out[q * 9 + e]));
        for (size_t q = 0; q < n; q += 97) { checksum += out[q * 9]; omp_checksum += P[q * 3]; }
        printf("{\"level\": %d, \"patches\": %d, \"vertices\": %zu, \"median_s\": %.9g, \"threads\": %d, "
               "\"threads_median_s\": %.9g, \"omp_median_s\": %.9g, \"checksum\": %.9g, \"omp_checksum\": %.9g, "
               "\"max_abs_diff_omp\": %.3g}\n",
               L, nf, n, single, threads, multi, omp, checksum, omp_checksum, diff);
    }
    delete cpt;
    return 0;
}
