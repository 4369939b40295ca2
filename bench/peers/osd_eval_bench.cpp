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


// Median seconds of `run` over `repeats` timed runs after one warm-up run.
static double median_seconds(int repeats, const std::function<void()> &run) {
    std::vector<double> times;
    for (int rep = 0; rep < repeats + 1; ++rep) {
        auto t0 = std::chrono::steady_clock::now();
        run();
        auto t1 = std::chrono::steady_clock::now();
        if (rep > 0) times.push_back(std::chrono::duration<double>(t1 - t0).count());
    }
    std::sort(times.begin(), times.end());
    size_t m = times.size();
    return m % 2 ? times[m / 2] : 0.5 * (times[m / 2 - 1] + times[m / 2]);
}

// Every sample of faces [f0, f1): position, du, dv as float, 9 per sample, into out (sample-major).
static bool eval_faces(const Far::PatchTable *pt, const Far::PatchMap &pm, const std::vector<V3> &pts, int L,
                       int f0, int f1, float *out) {
    double w[20], wu[20], wv[20];
    size_t k = (size_t)f0 * (L + 1) * (L + 1);
    for (int f = f0; f < f1; ++f)
        for (int j = 0; j <= L; ++j)
            for (int i = 0; i <= L; ++i, ++k) {
                double u = (double)i / L, v = (double)j / L;
                Far::PatchTable::PatchHandle const *h = pm.FindPatch(f, u, v);
                if (!h) return false;
                pt->EvaluateBasis(*h, u, v, w, wu, wv);
                Far::ConstIndexArray cv = pt->GetPatchVertices(*h);
                double P[3] = {0, 0, 0}, Du[3] = {0, 0, 0}, Dv[3] = {0, 0, 0};
                for (int c = 0; c < cv.size(); ++c) {
                    const double *q = pts[cv[c]].p;
                    for (int e = 0; e < 3; ++e) { P[e] += w[c] * q[e]; Du[e] += wu[c] * q[e]; Dv[e] += wv[c] * q[e]; }
                }
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
    Far::TopologyDescriptor d;
    d.numVertices = (int)pos.size();
    d.numFaces = (int)nv.size();
    d.numVertsPerFace = nv.data();
    d.vertIndicesPerFace = idx.data();
    Sdc::Options o;
    o.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
    typedef Far::TopologyRefinerFactory<Far::TopologyDescriptor> F;
    Far::TopologyRefiner *r = F::Create(d, F::Options(Sdc::SCHEME_CATMARK, o));
    Far::PatchTableFactory::Options po(0);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.SetPatchPrecision<double>();
    r->RefineAdaptive(po.GetRefineAdaptiveOptions());
    Far::PatchTable const *pt = Far::PatchTableFactory::Create(*r, po);
    int nref = r->GetNumVerticesTotal();
    int nloc = pt->GetNumLocalPoints();
    std::vector<V3> pts(nref + nloc);
    std::copy(pos.begin(), pos.end(), pts.begin());
    if (nloc) pt->GetLocalPointStencilTable<double>()->UpdateValues(pts.data(), pts.data() + nref);
    Far::PatchMap pm(*pt);
    const int nf = (int)nv.size();
    const int threads = omp_get_max_threads();

    // The float path of Osd: a float patch table (the same patches), its local points in float, the
    // source buffer of refined + local points as x, y, z floats.
    Far::PatchTableFactory::Options pof(0);
    pof.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    Far::PatchTable const *ptf = Far::PatchTableFactory::Create(*r, pof);
    Osd::CpuPatchTable *cpt = Osd::CpuPatchTable::Create(ptf);
    Far::PatchMap pmf(*ptf);
    std::vector<V3f> srcv(nref + ptf->GetNumLocalPoints());
    for (int q = 0; q < nref; ++q)
        for (int e = 0; e < 3; ++e) srcv[q].p[e] = (float)pos[q].p[e];
    if (ptf->GetNumLocalPoints()) ptf->GetLocalPointStencilTable<float>()->UpdateValues(srcv.data(), srcv.data() + nref);
    const float *src = &srcv[0].p[0];
    Osd::BufferDescriptor srcDesc(0, 3, 3), dstDesc(0, 3, 3);

    for (int a = 3; a < argc; ++a) {
        int L = atoi(argv[a]);
        if (L < 1) { fprintf(stderr, "level %s is not positive\n", argv[a]); return 1; }
        size_t n = (size_t)nf * (L + 1) * (L + 1);
        std::vector<float> out(n * 9), out_mt(n * 9);
        bool ok = true;
        double single = median_seconds(repeats, [&] { ok = ok && eval_faces(pt, pm, pts, L, 0, nf, out.data()); });
        if (!ok) { fprintf(stderr, "FindPatch failed at level %d\n", L); return 1; }
        double multi = median_seconds(repeats, [&] {
            int failed = 0;
#pragma omp parallel for schedule(static) reduction(+ : failed)
            for (int f = 0; f < nf; ++f) failed += !eval_faces(pt, pm, pts, L, f, f + 1, out_mt.data());
            ok = ok && failed == 0;
        });
        if (!ok || out_mt != out) { fprintf(stderr, "the threaded loop differs from the single-thread one\n"); return 1; }

        std::vector<Osd::PatchCoord> coords(n);
        size_t k = 0;
        for (int f = 0; f < nf; ++f)
            for (int j = 0; j <= L; ++j)
                for (int i = 0; i <= L; ++i, ++k) {
                    float u = (float)i / L, v = (float)j / L;
                    Far::PatchTable::PatchHandle const *h = pmf.FindPatch(f, u, v);
                    if (!h) { fprintf(stderr, "FindPatch (float) failed face %d\n", f); return 1; }
                    coords[k] = Osd::PatchCoord(*h, u, v);
                }
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
    delete ptf;
    delete pt;
    delete r;
    return 0;
}
