// Shared by the OpenSubdiv peers of `gregvox bench` (osd_eval_bench.cpp, osd_glcompute_bench.cpp,
// osd_ptex_bench.cpp): the median timer, the point types Far's stencil and patch evaluation fill, the OBJ cage
// readers with their checks (missing file, no faces, an index out of range, for the quad reader a face that
// is not a quad: one line on stderr, false; the tagged reader keeps OpenSubdiv's `t` tags), the patch tables
// they evaluate (built as tests/oracle/osd_gregory.cpp builds them), and one sample of the double CPU
// reference.
#pragma once
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/osd/types.h>
#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <memory>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

struct V3 {
    double p[3];
    void Clear(void * = 0) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(V3 const &s, double w) { for (int k = 0; k < 3; ++k) p[k] += w * s.p[k]; }
};

struct V3f {
    float p[3];
    void Clear(void * = 0) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(V3f const &s, float w) { for (int k = 0; k < 3; ++k) p[k] += w * s.p[k]; }
};
static_assert(sizeof(V3f) == 3 * sizeof(float), "a buffer of x, y, z floats");

// A cage of any polygons with the OpenSubdiv tags the regression shapes carry (`t crease`, `t corner`,
// `t hole`, `t interpolateboundary`, `t creasemethod`; other `t` lines are ignored here: gregvox refuses
// the ones it does not know before the bench runs), 0-based indices as in far_utils.h.
struct TaggedCage {
    std::vector<V3> pos;
    std::vector<int> nv, idx, crease_pairs, corners, holes;
    std::vector<float> crease_w, corner_w;
    OpenSubdiv::Sdc::Options::VtxBoundaryInterpolation boundary =
        OpenSubdiv::Sdc::Options::VTX_BOUNDARY_EDGE_ONLY;
    bool chaikin = false;
    // Face-varying UVs: `vt` values (u, v pairs) and one index per face corner (empty without UVs), and
    // `t facevaryinginterpolateboundary` (gregvox's default without the tag: 1, FVAR_LINEAR_CORNERS_ONLY).
    std::vector<double> uvs;
    std::vector<int> uv_idx;
    int fvar_rule = 1;
    // Tag names read but not applied (the oracle refuses them; the bench peers ignore them).
    std::vector<std::string> unknown;
};

// Reads a tagged cage; false (after one stderr line) when it cannot be read, has no faces or an index is out
// of range.
static bool read_tagged_cage(const char *path, TaggedCage &c) {
    std::ifstream in(path);
    if (!in) { fprintf(stderr, "%s: cannot open\n", path); return false; }
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ss(line);
        std::string tag;
        ss >> tag;
        if (tag == "v") { V3 v; ss >> v.p[0] >> v.p[1] >> v.p[2]; c.pos.push_back(v); }
        else if (tag == "vt") { double u = 0, v = 0; ss >> u >> v; c.uvs.push_back(u); c.uvs.push_back(v); }
        else if (tag == "f") {
            std::string tok; int n = 0;
            while (ss >> tok) {
                int i = atoi(tok.c_str()); if (i < 0) i = (int)c.pos.size() + i + 1; c.idx.push_back(i - 1); ++n;
                size_t slash = tok.find('/');
                if (slash != std::string::npos && slash + 1 < tok.size() && tok[slash + 1] != '/') {
                    int t = atoi(tok.c_str() + slash + 1);
                    if (t < 0) t = (int)(c.uvs.size() / 2) + t + 1;
                    c.uv_idx.push_back(t - 1);
                }
            }
            c.nv.push_back(n);
        } else if (tag == "t") {
            std::string name, counts;
            ss >> name >> counts;
            int ni = 0, nfl = 0, ns = 0;
            sscanf(counts.c_str(), "%d/%d/%d", &ni, &nfl, &ns);
            std::vector<int> iv(ni);
            std::vector<float> fv(nfl);
            std::string sv;
            for (auto &x : iv) ss >> x;
            for (auto &x : fv) ss >> x;
            if (ns) ss >> sv;
            auto weight = [&](int k) { return nfl == 0 ? 0.0f : std::max(0.0f, nfl > 1 ? fv[k] : fv[0]); };
            if (name == "crease") {
                for (int j = 0; j + 1 < ni; j += 2) {
                    c.crease_pairs.push_back(iv[j]); c.crease_pairs.push_back(iv[j + 1]);
                    c.crease_w.push_back(weight(j / 2));
                }
            } else if (name == "corner") {
                for (int j = 0; j < ni; ++j) { c.corners.push_back(iv[j]); c.corner_w.push_back(weight(j)); }
            } else if (name == "hole") {
                for (int j = 0; j < ni; ++j) c.holes.push_back(iv[j]);
            } else if (name == "interpolateboundary" && ni == 1) {
                c.boundary = iv[0] == 0 ? OpenSubdiv::Sdc::Options::VTX_BOUNDARY_NONE
                           : iv[0] == 1 ? OpenSubdiv::Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER
                                        : OpenSubdiv::Sdc::Options::VTX_BOUNDARY_EDGE_ONLY;
            } else if (name == "creasemethod") {
                c.chaikin = (sv == "chaikin");
            } else if (name == "facevaryinginterpolateboundary" && ni == 1) {
                c.fvar_rule = iv[0];
            } else if (name != "facevaryinginterpolateboundary") {
                c.unknown.push_back(name);
            }
        }
    }
    if (c.nv.empty()) { fprintf(stderr, "%s: no faces\n", path); return false; }
    for (int i : c.idx) if (i < 0 || i >= (int)c.pos.size()) { fprintf(stderr, "%s: face index out of range\n", path); return false; }
    // UVs only when every corner names one (gregvox's rule too).
    if (c.uv_idx.size() != c.idx.size()) c.uv_idx.clear();
    for (int i : c.uv_idx) if (i < 0 || i >= (int)c.uvs.size() / 2) { fprintf(stderr, "%s: uv index out of range\n", path); return false; }
    return true;
}

// Reads the `v` and `f` lines of an OBJ (negative indices relative, texture/normal indices ignored) into
// positions, vertices per face and 0-based face indices; false (after one stderr line) unless it is a
// non-empty all-quad cage whose indices are in range.
static bool read_quad_cage(const char *path, std::vector<V3> &pos, std::vector<int> &nv, std::vector<int> &idx) {
    TaggedCage c;
    if (!read_tagged_cage(path, c)) return false;
    for (int n : c.nv) if (n != 4) { fprintf(stderr, "%s: not an all-quad cage\n", path); return false; }
    pos = c.pos;
    nv = c.nv;
    idx = c.idx;
    return true;
}

// The Far set-up of a cage: the CATMARK refiner (VTX_BOUNDARY_EDGE_ONLY) refined adaptively for
// ENDCAP_GREGORY_BASIS at isolation 0; the double patch table with the refined + local points and its patch
// map (the CPU reference), and the float patch table (the same patches) with its points as x, y, z floats
// and its patch map (what the Osd evaluators read). Owns everything it holds.
struct GregoryTables {
    std::unique_ptr<OpenSubdiv::Far::TopologyRefiner> refiner;
    std::unique_ptr<const OpenSubdiv::Far::PatchTable> pt, ptf;
    std::unique_ptr<OpenSubdiv::Far::PatchMap> pm, pmf;
    std::vector<V3> pts;
    std::vector<V3f> ptsf;
    int nref = 0;
};

// Builds `t` from a cage read by read_quad_cage; false (after one stderr line naming `path`) if Far fails.
static bool make_gregory_tables(const char *path, const std::vector<V3> &pos, std::vector<int> &nv,
                                std::vector<int> &idx, GregoryTables &t) {
    namespace Far = OpenSubdiv::Far;
    Far::TopologyDescriptor d;
    d.numVertices = (int)pos.size();
    d.numFaces = (int)nv.size();
    d.numVertsPerFace = nv.data();
    d.vertIndicesPerFace = idx.data();
    OpenSubdiv::Sdc::Options o;
    o.SetVtxBoundaryInterpolation(OpenSubdiv::Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
    typedef Far::TopologyRefinerFactory<Far::TopologyDescriptor> F;
    t.refiner.reset(F::Create(d, F::Options(OpenSubdiv::Sdc::SCHEME_CATMARK, o)));
    if (!t.refiner) { fprintf(stderr, "%s: Far::TopologyRefinerFactory::Create failed\n", path); return false; }
    Far::PatchTableFactory::Options po(0);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.SetPatchPrecision<double>();
    t.refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
    t.pt.reset(Far::PatchTableFactory::Create(*t.refiner, po));
    t.nref = t.refiner->GetNumVerticesTotal();
    t.pts.assign(t.nref + t.pt->GetNumLocalPoints(), V3());
    std::copy(pos.begin(), pos.end(), t.pts.begin());
    if (t.pt->GetNumLocalPoints())
        t.pt->GetLocalPointStencilTable<double>()->UpdateValues(t.pts.data(), t.pts.data() + t.nref);
    t.pm.reset(new Far::PatchMap(*t.pt));
    Far::PatchTableFactory::Options pof(0);
    pof.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    t.ptf.reset(Far::PatchTableFactory::Create(*t.refiner, pof));
    t.pmf.reset(new Far::PatchMap(*t.ptf));
    t.ptsf.assign(t.nref + t.ptf->GetNumLocalPoints(), V3f());
    for (int q = 0; q < t.nref; ++q)
        for (int e = 0; e < 3; ++e) t.ptsf[q].p[e] = (float)pos[q].p[e];
    if (t.ptf->GetNumLocalPoints())
        t.ptf->GetLocalPointStencilTable<float>()->UpdateValues(t.ptsf.data(), t.ptsf.data() + t.nref);
    return true;
}

// One sample of face f at (u, v) in double: FindPatch + EvaluateBasis + the weighted sums of position and
// both first derivatives; false where FindPatch finds no patch.
static inline bool cpu_sample(const GregoryTables &t, int f, double u, double v, double P[3], double Du[3],
                              double Dv[3]) {
    double w[20], wu[20], wv[20];
    OpenSubdiv::Far::PatchTable::PatchHandle const *h = t.pm->FindPatch(f, u, v);
    if (!h) return false;
    t.pt->EvaluateBasis(*h, u, v, w, wu, wv);
    OpenSubdiv::Far::ConstIndexArray cv = t.pt->GetPatchVertices(*h);
    for (int e = 0; e < 3; ++e) P[e] = Du[e] = Dv[e] = 0;
    for (int c = 0; c < cv.size(); ++c) {
        const double *q = t.pts[cv[c]].p;
        for (int e = 0; e < 3; ++e) { P[e] += w[c] * q[e]; Du[e] += wu[c] * q[e]; Dv[e] += wv[c] * q[e]; }
    }
    return true;
}

// The float patch coordinates of every sample (face-major, rows of u inner) at level L, found once before
// timing as an application re-evaluating a fixed sampling does; false (after one stderr line) where
// FindPatch finds no patch.
static bool patch_coords(const GregoryTables &t, int L, std::vector<OpenSubdiv::Osd::PatchCoord> &coords) {
    const int nf = t.refiner->GetLevel(0).GetNumFaces();
    coords.resize((size_t)nf * (L + 1) * (L + 1));
    size_t k = 0;
    for (int f = 0; f < nf; ++f)
        for (int j = 0; j <= L; ++j)
            for (int i = 0; i <= L; ++i, ++k) {
                float u = (float)i / L, v = (float)j / L;
                OpenSubdiv::Far::PatchTable::PatchHandle const *h = t.pmf->FindPatch(f, u, v);
                if (!h) { fprintf(stderr, "FindPatch (float) failed face %d\n", f); return false; }
                coords[k] = OpenSubdiv::Osd::PatchCoord(*h, u, v);
            }
    return true;
}

// The isolation level gregvox uses by default: the largest semi-sharp sharpness rounded up, at least 1 with
// non-quad faces.
static int default_isolation(const TaggedCage &c) {
    float semi = 0;
    for (float w : c.crease_w) if (w > 0 && w < 10) semi = std::max(semi, w);
    for (float w : c.corner_w) if (w > 0 && w < 10) semi = std::max(semi, w);
    bool quads = true;
    for (int n : c.nv) quads &= (n == 4);
    return std::max((int)std::ceil(semi), quads ? 0 : 1);
}

// Far's refiner of a tagged cage (CATMARK, its boundary rule, creasing method, creases, corners and holes;
// with `fvar` and UVs, the UVs as face-varying channel 0 under the cage's FVarLinearInterpolation),
// unrefined; null if Far refuses the cage.
static OpenSubdiv::Far::TopologyRefiner *make_tagged_refiner(const TaggedCage &c, bool fvar = false) {
    namespace Far = OpenSubdiv::Far;
    Far::TopologyDescriptor d;
    d.numVertices = (int)c.pos.size();
    d.numFaces = (int)c.nv.size();
    d.numVertsPerFace = c.nv.data();
    d.vertIndicesPerFace = c.idx.data();
    d.numCreases = (int)c.crease_w.size();
    d.creaseVertexIndexPairs = c.crease_pairs.data();
    d.creaseWeights = c.crease_w.data();
    d.numCorners = (int)c.corner_w.size();
    d.cornerVertexIndices = c.corners.data();
    d.cornerWeights = c.corner_w.data();
    d.numHoles = (int)c.holes.size();
    d.holeIndices = c.holes.data();
    Far::TopologyDescriptor::FVarChannel channel;
    OpenSubdiv::Sdc::Options o;
    if (fvar && !c.uv_idx.empty()) {
        channel.numValues = (int)c.uvs.size() / 2;
        channel.valueIndices = c.uv_idx.data();
        d.numFVarChannels = 1;
        d.fvarChannels = &channel;
        o.SetFVarLinearInterpolation((OpenSubdiv::Sdc::Options::FVarLinearInterpolation)c.fvar_rule);
    }
    o.SetVtxBoundaryInterpolation(c.boundary);
    if (c.chaikin) o.SetCreasingMethod(OpenSubdiv::Sdc::Options::CREASE_CHAIKIN);
    typedef Far::TopologyRefinerFactory<Far::TopologyDescriptor> F;
    return F::Create(d, F::Options(OpenSubdiv::Sdc::SCHEME_CATMARK, o));
}

// Far for a tagged cage at isolation L: the refiner (RefineAdaptive(L), useInfSharpPatch, Gregory basis end
// caps) with its tags, and the double (`pt`, `pts`, `pm`) and float (`ptf`, `ptsf`, `pmf`) patch tables with
// every refined and local point. False (after one stderr line) if Far refuses the cage.
static bool make_tagged_tables(const char *path, const TaggedCage &c, int L, GregoryTables &t) {
    namespace Far = OpenSubdiv::Far;
    t.refiner.reset(make_tagged_refiner(c));
    if (!t.refiner) { fprintf(stderr, "%s: Far::TopologyRefinerFactory::Create failed\n", path); return false; }
    Far::PatchTableFactory::Options po(L);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.useInfSharpPatch = true;
    po.SetPatchPrecision<double>();
    t.refiner->RefineAdaptive(po.GetRefineAdaptiveOptions());
    t.pt.reset(Far::PatchTableFactory::Create(*t.refiner, po));
    t.nref = t.refiner->GetNumVerticesTotal();
    t.pts.assign(t.nref + t.pt->GetNumLocalPoints(), V3());
    std::copy(c.pos.begin(), c.pos.end(), t.pts.begin());
    Far::PrimvarRefinerReal<double> pr(*t.refiner);
    int off = 0;
    for (int l = 1; l <= t.refiner->GetMaxLevel(); ++l) {
        V3 *src = t.pts.data() + off;
        V3 *dst = src + t.refiner->GetLevel(l - 1).GetNumVertices();
        pr.Interpolate(l, src, dst);
        off += t.refiner->GetLevel(l - 1).GetNumVertices();
    }
    if (t.pt->GetNumLocalPoints())
        t.pt->GetLocalPointStencilTable<double>()->UpdateValues(t.pts.data(), t.pts.data() + t.nref);
    t.pm.reset(new Far::PatchMap(*t.pt));
    Far::PatchTableFactory::Options pof(L);
    pof.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    pof.useInfSharpPatch = true;
    t.ptf.reset(Far::PatchTableFactory::Create(*t.refiner, pof));
    t.pmf.reset(new Far::PatchMap(*t.ptf));
    t.ptsf.assign(t.nref + t.ptf->GetNumLocalPoints(), V3f());
    for (int q = 0; q < t.nref; ++q)
        for (int e = 0; e < 3; ++e) t.ptsf[q].p[e] = (float)t.pts[q].p[e];
    if (t.ptf->GetNumLocalPoints())
        t.ptf->GetLocalPointStencilTable<float>()->UpdateValues(t.ptsf.data(), t.ptsf.data() + t.nref);
    return true;
}
