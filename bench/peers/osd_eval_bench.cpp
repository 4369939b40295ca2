// OpenSubdiv peer for `gregvox bench` (suite `gregory`): single-thread CPU evaluation of the same samples
// gregvox evaluates — every face of an all-quad cage, (level+1)^2 samples on the uniform grid u,v = i/level,
// position and both first derivatives — with Far's patch table built exactly as tests/oracle/osd_gregory.cpp
// builds it (isolation 0, CATMARK, VTX_BOUNDARY_EDGE_ONLY, ENDCAP_GREGORY_BASIS, double precision), so the
// patches are the ones gregvox's ACC-2 stencils reproduce.
//
// Timed: the evaluation loop only (PatchMap::FindPatch + PatchTable::EvaluateBasis + the weighted sums,
// written to an output array), i.e. the same work as gregvox's `gregory_eval` pass; the patch table and the
// local (Gregory basis) points are built once before timing, like gregvox's stencils and W·cage.
//
// Build: c++ -O2 -std=c++14 -o osd_eval_bench osd_eval_bench.cpp -losdCPU     (bench/peers/build.sh)
// Usage: osd_eval_bench CAGE.obj REPEATS LEVEL...
// Output: one JSON object per level on stdout:
//   {"level": L, "patches": F, "vertices": F*(L+1)^2, "median_s": S, "checksum": C}
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/stencilTable.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace OpenSubdiv;

struct V3 {
    double p[3];
    void Clear(void * = 0) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(V3 const &s, double w) { for (int k = 0; k < 3; ++k) p[k] += w * s.p[k]; }
};

int main(int argc, char **argv) {
    if (argc < 4) { fprintf(stderr, "usage: %s CAGE.obj REPEATS LEVEL...\n", argv[0]); return 2; }
    std::vector<V3> pos;
    std::vector<int> nv, idx;
    {
        std::ifstream in(argv[1]);
        if (!in) { fprintf(stderr, "%s: cannot open\n", argv[1]); return 1; }
        std::string line;
        while (std::getline(in, line)) {
            std::istringstream ss(line);
            std::string tag;
            ss >> tag;
            if (tag == "v") { V3 v; ss >> v.p[0] >> v.p[1] >> v.p[2]; pos.push_back(v); }
            else if (tag == "f") {
                std::string tok; int n = 0;
                while (ss >> tok) { int i = atoi(tok.c_str()); if (i < 0) i = (int)pos.size() + i + 1; idx.push_back(i - 1); ++n; }
                nv.push_back(n);
            }
        }
    }
    for (int n : nv) if (n != 4) { fprintf(stderr, "%s: not an all-quad cage\n", argv[1]); return 1; }
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
    double w[20], wu[20], wv[20];
    for (int a = 3; a < argc; ++a) {
        int L = atoi(argv[a]);
        if (L < 1) { fprintf(stderr, "level %s is not positive\n", argv[a]); return 1; }
        size_t n = (size_t)nf * (L + 1) * (L + 1);
        std::vector<float> out(n * 9);
        std::vector<double> times;
        double checksum = 0;
        for (int rep = 0; rep < repeats + 1; ++rep) {  // one warm-up run, not counted
            auto t0 = std::chrono::steady_clock::now();
            size_t k = 0;
            for (int f = 0; f < nf; ++f)
                for (int j = 0; j <= L; ++j)
                    for (int i = 0; i <= L; ++i, ++k) {
                        double u = (double)i / L, v = (double)j / L;
                        Far::PatchTable::PatchHandle const *h = pm.FindPatch(f, u, v);
                        if (!h) { fprintf(stderr, "FindPatch failed face %d\n", f); return 1; }
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
            auto t1 = std::chrono::steady_clock::now();
            if (rep > 0) times.push_back(std::chrono::duration<double>(t1 - t0).count());
            checksum = 0;
            for (size_t q = 0; q < n; q += 97) checksum += out[q * 9];
        }
        std::sort(times.begin(), times.end());
        size_t m = times.size();
        double med = m % 2 ? times[m / 2] : 0.5 * (times[m / 2 - 1] + times[m / 2]);
        printf("{\"level\": %d, \"patches\": %d, \"vertices\": %zu, \"median_s\": %.9g, \"checksum\": %.9g}\n", L, nf, n, med, checksum);
    }
    delete pt;
    delete r;
    return 0;
}
