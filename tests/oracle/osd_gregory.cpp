// OpenSubdiv oracle for gregvox's ACC-2 stencils (docs/notes/gregory.md §4.3). Not run by the tests: it writes the
// fixtures in tests/fixtures/surface/ once (see build_osd.sh) and the Rust tests read them. The OBJ reader with
// OpenSubdiv's tags and the tagged refiner are bench/peers/osd_cage.h's, shared with the bench's peers.
//
// Per cage: Far at isolation 0, Sdc CATMARK with VTX_BOUNDARY_EDGE_ONLY (or the cage's `t interpolateboundary`),
// the cage's infinitely sharp `t crease`/`t corner` tags and `t hole`s, useInfSharpPatch, ENDCAP_GREGORY_BASIS,
// double precision patches; local (Gregory basis) points from the double local point stencil table appended after
// the cage vertices. For an all-quad cage at isolation 0 the ptex face of patch f is base face f.
//
// Per patch we write 20 points in GREGORY_BASIS order:
// - GREGORY_BASIS patches: the 20 points as OpenSubdiv computed them (corner i = face vertex i).
// - REGULAR patches (B-spline, 16 points, possibly with a boundary mask and phantom points): converted to the
//   bicubic Bezier form by *evaluation*: EvaluateBasis at the 4x4 grid (u,v) in {0,1/3,2/3,1}^2 and the
//   inverse of the cubic Bernstein collocation matrix on both sides. Each interior pair gets the same point.
//   This handles every boundary mask and any patch rotation without reproducing OpenSubdiv's conventions.
// Optional samples: (u, v, P, dP/du, dP/dv) from EvaluateBasis (OpenSubdiv's default, approximate
// Gregory derivatives inside the patch, exact on the edges).
//
// Binary layout (little endian), file "<name>.osd":
//   char[8] "GVOSD001"
//   u32 n_verts, u32 n_faces, u32 point_bytes (4 = f32 points, 8 = f64), u32 n_samples (per patch)
//   f64 cage[n_verts][3]
//   u32 face_ptr[n_faces + 1], u32 indices[face_ptr[n_faces]]
//   u32 patch_type[n_faces]            (0 = REGULAR converted to Bezier, 1 = GREGORY_BASIS, 2 = hole: no patch,
//                                       its points zero, 3 = GREGORY_BASIS whose face points OpenSubdiv 3.5
//                                       computed with a non-affine row: compare P, Ep, Em only)
//   point_bytes points[n_faces][20][3]
//   f64 samples[n_faces][n_samples][11] (u, v, P.xyz, Du.xyz, Dv.xyz)
//
// With --limit FILE: also the exact Catmull-Clark limit of every cage vertex from Far::PrimvarRefiner::Limit
// (Sdc limit position and tangent masks on the unrefined cage): f64 [n_verts][9] = P, tan1, tan2.
//
// Usage: osd_gregory IN.obj OUT.osd [--refine] [--f32] [--samples] [--limit FILE]
//   --refine: one uniform Catmull-Clark step by Far first (for non-quad cages); the refined cage is what
//             the fixture stores, so the Rust test uses OpenSubdiv's vertex numbering.
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/stencilTable.h>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../../bench/peers/osd_cage.h"

using namespace OpenSubdiv;

typedef TaggedCage Cage;

// The cage file and its tags; exits on a tag the oracle would not apply (so no fixture silently ignores one).
static Cage read_obj(const char *path) {
    Cage c;
    if (!read_tagged_cage(path, c)) exit(1);
    if (!c.unknown.empty()) { fprintf(stderr, "%s: tag '%s' not handled by the oracle\n", path, c.unknown[0].c_str()); exit(1); }
    return c;
}

static Far::TopologyRefiner *make_refiner(const Cage &c) {
    Far::TopologyRefiner *r = make_tagged_refiner(c);
    if (!r) { fprintf(stderr, "OpenSubdiv refused the cage\n"); exit(1); }
    return r;
}

static Cage refine_once(const Cage &c) {
    Far::TopologyRefiner *r = make_refiner(c);
    Far::TopologyRefiner::UniformOptions uo(1);
    uo.fullTopologyInLastLevel = true; // edge-face relations for the refined tags
    r->RefineUniform(uo);
    std::vector<V3> all(r->GetNumVerticesTotal());
    std::copy(c.pos.begin(), c.pos.end(), all.begin());
    Far::PrimvarRefinerReal<double> pr(*r);
    V3 *src = all.data();
    V3 *dst = src + c.pos.size();
    pr.Interpolate(1, src, dst);
    Far::TopologyLevel const &l1 = r->GetLevel(1);
    Cage out;
    out.boundary = c.boundary;
    out.pos.assign(dst, dst + l1.GetNumVertices());
    for (int f = 0; f < l1.GetNumFaces(); ++f) {
        Far::ConstIndexArray fv = l1.GetFaceVertices(f);
        out.nv.push_back(fv.size());
        for (int k = 0; k < fv.size(); ++k) out.idx.push_back(fv[k]);
        if (l1.IsFaceHole(f)) out.holes.push_back(f);
    }
    // The refined level's infinite sharpness as tags (boundary edges are sharpened again by Sdc). Under
    // VTX_BOUNDARY_NONE the refined boundary faces are holes already (children of holes).
    for (int e = 0; e < l1.GetNumEdges(); ++e) {
        if (l1.GetEdgeSharpness(e) >= 10.0f && l1.GetEdgeFaces(e).size() == 2) {
            Far::ConstIndexArray ev = l1.GetEdgeVertices(e);
            out.crease_pairs.push_back(ev[0]); out.crease_pairs.push_back(ev[1]);
            out.crease_w.push_back(10.0f);
        }
    }
    for (int v = 0; v < l1.GetNumVertices(); ++v) {
        if (l1.GetVertexSharpness(v) >= 10.0f) { out.corners.push_back(v); out.corner_w.push_back(10.0f); }
    }

    delete r;
    return out;
}

// Cubic Bernstein basis.
static void bern(double t, double b[4]) {
    double s = 1 - t;
    b[0] = s * s * s; b[1] = 3 * t * s * s; b[2] = 3 * t * t * s; b[3] = t * t * t;
}

// Inverse of A[i][k] = B_k(i/3) by Gauss-Jordan.
static void bern_inverse(double inv[4][4]) {
    double a[4][8];
    for (int i = 0; i < 4; ++i) {
        double b[4]; bern(i / 3.0, b);
        for (int k = 0; k < 4; ++k) { a[i][k] = b[k]; a[i][4 + k] = (i == k); }
    }
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r) if (fabs(a[r][c]) > fabs(a[piv][c])) piv = r;
        for (int k = 0; k < 8; ++k) std::swap(a[c][k], a[piv][k]);
        double d = a[c][c];
        for (int k = 0; k < 8; ++k) a[c][k] /= d;
        for (int r = 0; r < 4; ++r) if (r != c) {
            double m = a[r][c];
            for (int k = 0; k < 8; ++k) a[r][k] -= m * a[c][k];
        }
    }
    for (int i = 0; i < 4; ++i) for (int k = 0; k < 4; ++k) inv[i][k] = a[i][4 + k];
}

// Bezier grid b[row=v][col=u] -> GREGORY_BASIS index pairs (docs/notes/gregory.md §1.2).
static const int GRID[4][4][2] = {
    {{0, 0}, {1, 1}, {7, 7}, {5, 5}},
    {{2, 2}, {3, 4}, {9, 8}, {6, 6}},
    {{16, 16}, {19, 18}, {13, 14}, {12, 12}},
    {{15, 15}, {17, 17}, {11, 11}, {10, 10}},
};

// The ptex faces of a cage as Far numbers them (a quad one, an n-gon n), holes left out.
static std::vector<int> ptex_faces(const Cage &cage, Far::TopologyRefiner const &r) {
    std::vector<int> out;
    int id = 0;
    for (size_t f = 0; f < cage.nv.size(); ++f) {
        int k = cage.nv[f] == 4 ? 1 : cage.nv[f];
        for (int i = 0; i < k; ++i, ++id) if (!r.GetLevel(0).IsFaceHole((int)f)) out.push_back(id);
    }
    return out;
}

// The samples' generator (xorshift64*, fixed seed): uniform doubles in [0, 1).
struct Rng {
    uint64_t s = 0x9E3779B97F4A7C15ull;
    double next() { s ^= s >> 12; s ^= s << 25; s ^= s >> 27; return (double)((s * 0x2545F4914F6CDD1Dull) >> 11) / 9007199254740992.0; }
};

// --faces A B: draw --ptex samples on ptex faces A..B-1 only (where a large cage's features are).
static int g_face_lo = 0, g_face_hi = 1 << 30;
// --fd FILE (with --ptex): the exact derivatives of OpenSubdiv's own positions at each sample, by
// differences of EvaluateBasis positions on the sample's patch (OpenSubdiv's Gregory derivatives freeze
// the rational points, so they are not these): u32 n; per sample f64[6]: dP/du, dP/dv (ptex u, v).
static const char *g_fd_path = 0;

// --ptex N FILE [--isolation L]: N random (ptex face, u, v) on the cage as given, through Far::PatchMap and
// EvaluateBasis, with RefineAdaptive(L), L at least the largest semi-sharp sharpness rounded up, at least 1
// with non-quad faces:
//   u32 n; per sample f64[13]: face, u, v, P.xyz, Du.xyz, Dv.xyz, patch type (0 REGULAR, 1 GREGORY_BASIS).
// The Gregory derivatives are OpenSubdiv's approximation; REGULAR ones are exact.
static int write_ptex_samples(const Cage &cage, int n, const char *path, int isolation) {
    int level = std::max(default_isolation(cage), isolation);
    Far::TopologyRefiner *r = make_refiner(cage);
    Far::PatchTableFactory::Options po(level);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.useInfSharpPatch = true;
    po.SetPatchPrecision<double>();
    Far::TopologyRefiner::AdaptiveOptions ao = po.GetRefineAdaptiveOptions();
    r->RefineAdaptive(ao);
    Far::PatchTable const *pt = Far::PatchTableFactory::Create(*r, po);
    int nref = r->GetNumVerticesTotal();
    int nloc = pt->GetNumLocalPoints();
    std::vector<V3> pts(nref + nloc);
    std::copy(cage.pos.begin(), cage.pos.end(), pts.begin());
    Far::PrimvarRefinerReal<double> pr(*r);
    for (int l = 1; l <= r->GetMaxLevel(); ++l) {
        int off = 0;
        for (int k = 0; k < l - 1; ++k) off += r->GetLevel(k).GetNumVertices();
        V3 *src = pts.data() + off;
        V3 *dst = src + r->GetLevel(l - 1).GetNumVertices();
        pr.Interpolate(l, src, dst);
    }
    if (nloc) pt->GetLocalPointStencilTable<double>()->UpdateValues(pts.data(), pts.data() + nref);
    Far::PatchMap pm(*pt);
    std::vector<int> ptex_face;
    for (int f : ptex_faces(cage, *r)) if (f >= g_face_lo && f < g_face_hi) ptex_face.push_back(f);
    if (ptex_face.empty()) { fprintf(stderr, "--faces: no ptex face in range\n"); return 1; }
    std::vector<double> out, fd;
    std::vector<double> w(20), wu(20), wv(20);
    Rng rng;
    auto next = [&]() { return rng.next(); };
    for (int s = 0; s < n; ++s) {
        int face = ptex_face[(size_t)(next() * ptex_face.size()) % ptex_face.size()];
        double u = next(), v = next();
        if (s % 10 == 0) u = 0.5; // the seams between refined quadrants
        Far::PatchTable::PatchHandle const *h = pm.FindPatch(face, u, v);
        if (!h) { fprintf(stderr, "FindPatch failed: ptex %d (%g, %g)\n", face, u, v); return 1; }
        if (g_fd_path) {
            // Differences in the patch's own parameters (s, t), mapped back to the ptex face's: central
            // where the stencil stays inside the patch, second-order one-sided at its edges.
            Far::PatchParam param = pt->GetPatchParam(*h);
            double ps = u, pq = v;
            param.Normalize(ps, pq);
            const double d = 1e-5;
            auto at = [&](double a, double b, double P[3], double uv[2]) {
                double uu = a, vv = b;
                param.Unnormalize(uu, vv);
                std::vector<double> ww(20);
                pt->EvaluateBasis(*h, uu, vv, ww.data());
                Far::ConstIndexArray cv = pt->GetPatchVertices(*h);
                for (int c = 0; c < 3; ++c) P[c] = 0;
                for (int k = 0; k < cv.size(); ++k) for (int c = 0; c < 3; ++c) P[c] += ww[k] * pts[cv[k]].p[c];
                uv[0] = uu; uv[1] = vv;
            };
            for (int axis = 0; axis < 2; ++axis) {
                double x = axis == 0 ? ps : pq;
                double k[3], c[3];
                if (x - d >= 0 && x + d <= 1) { k[0] = -d; k[1] = d; k[2] = 0; c[0] = -0.5; c[1] = 0.5; c[2] = 0; }
                else if (x - d < 0) { k[0] = 0; k[1] = d; k[2] = 2 * d; c[0] = -1.5; c[1] = 2.0; c[2] = -0.5; }
                else { k[0] = 0; k[1] = -d; k[2] = -2 * d; c[0] = 1.5; c[1] = -2.0; c[2] = 0.5; }
                double D[3] = {0, 0, 0}, scale = 0;
                for (int m = 0; m < 3; ++m) {
                    if (c[m] == 0) continue;
                    double P[3], uv[2];
                    at(axis == 0 ? ps + k[m] : ps, axis == 0 ? pq : pq + k[m], P, uv);
                    for (int q = 0; q < 3; ++q) D[q] += c[m] * P[q];
                }
                // d(s)/d(u): the patch's parameters against the ptex face's (a power of two).
                double P0[3], uv0[2], P1[3], uv1[2];
                at(0.25, 0.25, P0, uv0);
                at(0.75, 0.75, P1, uv1);
                scale = (axis == 0 ? uv1[0] - uv0[0] : uv1[1] - uv0[1]) / 0.5;
                for (int q = 0; q < 3; ++q) fd.push_back(D[q] / (d * scale));
            }
        }
        pt->EvaluateBasis(*h, u, v, w.data(), wu.data(), wv.data());
        Far::ConstIndexArray cv = pt->GetPatchVertices(*h);
        double P[3] = {0, 0, 0}, Du[3] = {0, 0, 0}, Dv[3] = {0, 0, 0};
        for (int k = 0; k < cv.size(); ++k) for (int c = 0; c < 3; ++c) {
            P[c] += w[k] * pts[cv[k]].p[c]; Du[c] += wu[k] * pts[cv[k]].p[c]; Dv[c] += wv[k] * pts[cv[k]].p[c];
        }
        Far::PatchDescriptor d = pt->GetPatchDescriptor(*h);
        out.push_back(face); out.push_back(u); out.push_back(v);
        for (int c = 0; c < 3; ++c) out.push_back(P[c]);
        for (int c = 0; c < 3; ++c) out.push_back(Du[c]);
        for (int c = 0; c < 3; ++c) out.push_back(Dv[c]);
        out.push_back(d.GetType() == Far::PatchDescriptor::GREGORY_BASIS ? 1.0 : 0.0);
    }
    FILE *fo = fopen(path, "wb");
    if (!fo) { fprintf(stderr, "cannot write %s\n", path); return 1; }
    uint32_t nn = n;
    fwrite(&nn, 4, 1, fo);
    fwrite(out.data(), 8, out.size(), fo);
    fclose(fo);
    fprintf(stderr, "%s: %d ptex samples over %zu ptex faces (max level %d)\n", path, n, ptex_face.size(), r->GetMaxLevel());
    if (g_fd_path) {
        FILE *ff = fopen(g_fd_path, "wb");
        if (!ff) { fprintf(stderr, "cannot write %s\n", g_fd_path); return 1; }
        fwrite(&nn, 4, 1, ff);
        fwrite(fd.data(), 8, fd.size(), ff);
        fclose(ff);
    }
    delete pt; delete r;
    return 0;
}

// --fvar N FILE [--isolation L]: the cage's UVs (face-varying channel 0, `vt`) at N random (ptex face, u, v),
// drawn as --ptex draws them, through Far's face-varying patches: RefineAdaptive(L) as --ptex, with
// generateFVarTables and smooth face-varying patches (generateFVarLegacyLinearPatches off: B-spline patches
// where the UVs are regular, Gregory basis end caps where not, on the face-varying topology; its refinement
// then isolates face-varying features too, considerFVarChannels) under the cage's
// `t facevaryinginterpolateboundary` (1, FVAR_LINEAR_CORNERS_ONLY, without it):
//   u32 n; per sample f64[9]: face, u, v, P.xyz, uv, flag.
// flag 1: the sample's face-varying patch may hold a truncated face point: OpenSubdiv 3.5's GregoryConverter
// sizes the face point between two sharp corners at 2 (getIrregularFacePointSize) while
// computeIrregularFacePoint writes the corner, both edge points and the ring terms, so that row is truncated
// and the patch is not the one it means to build (only the UV rules that sharpen spans of more than one face,
// 2-4, make such corners). Compare those samples' UVs loosely.
static int write_fvar_samples(const Cage &cage, int n, const char *path, int isolation) {
    if (cage.uv_idx.empty()) { fprintf(stderr, "%s: the cage has no UVs\n", path); return 1; }
    int level = std::max(default_isolation(cage), isolation);
    Far::TopologyRefiner *r = make_tagged_refiner(cage, true);
    if (!r) { fprintf(stderr, "OpenSubdiv refused the cage\n"); return 1; }
    Far::PatchTableFactory::Options po(level);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.useInfSharpPatch = true;
    po.SetPatchPrecision<double>();
    po.SetFVarPatchPrecision<double>();
    po.generateFVarTables = true;
    po.generateFVarLegacyLinearPatches = false;
    r->RefineAdaptive(po.GetRefineAdaptiveOptions());
    Far::PatchTable const *pt = Far::PatchTableFactory::Create(*r, po);
    int nref = r->GetNumVerticesTotal();
    int nloc = pt->GetNumLocalPoints();
    std::vector<V3> pts(nref + nloc);
    std::copy(cage.pos.begin(), cage.pos.end(), pts.begin());
    Far::PrimvarRefinerReal<double> pr(*r);
    int nfv = 0;
    for (int l = 0; l <= r->GetMaxLevel(); ++l) nfv += r->GetLevel(l).GetNumFVarValues(0);
    int nlocfv = pt->GetNumLocalPointsFaceVarying(0);
    std::vector<V3> fv(nfv + nlocfv);
    for (size_t i = 0; i < cage.uvs.size() / 2; ++i) { fv[i].p[0] = cage.uvs[2 * i]; fv[i].p[1] = cage.uvs[2 * i + 1]; fv[i].p[2] = 0; }
    int off = 0, offv = 0;
    for (int l = 1; l <= r->GetMaxLevel(); ++l) {
        V3 *src = pts.data() + off;
        V3 *dst = src + r->GetLevel(l - 1).GetNumVertices();
        pr.Interpolate(l, src, dst);
        off += r->GetLevel(l - 1).GetNumVertices();
        V3 *fsrc = fv.data() + offv;
        V3 *fdst = fsrc + r->GetLevel(l - 1).GetNumFVarValues(0);
        pr.InterpolateFaceVarying(l, fsrc, fdst, 0);
        offv += r->GetLevel(l - 1).GetNumFVarValues(0);
    }
    if (nloc) pt->GetLocalPointStencilTable<double>()->UpdateValues(pts.data(), pts.data() + nref);
    if (nlocfv) pt->GetLocalPointFaceVaryingStencilTable<double>(0)->UpdateValues(fv.data(), fv.data() + nfv);
    Far::PatchMap pm(*pt);
    std::vector<int> ptex_face;
    for (int f : ptex_faces(cage, *r)) if (f >= g_face_lo && f < g_face_hi) ptex_face.push_back(f);
    if (ptex_face.empty()) { fprintf(stderr, "--faces: no ptex face in range\n"); return 1; }
    std::vector<double> out;
    std::vector<double> w(20), wu(20), wv(20);
    Rng rng;
    auto next = [&]() { return rng.next(); };
    for (int s = 0; s < n; ++s) {
        int face = ptex_face[(size_t)(next() * ptex_face.size()) % ptex_face.size()];
        double u = next(), v = next();
        if (s % 10 == 0) u = 0.5;
        if (s % 10 == 1) { u = (s / 10) % 2 ? 0.0 : 1.0; } // the ptex face's own edges: seams, boundaries
        Far::PatchTable::PatchHandle const *h = pm.FindPatch(face, u, v);
        if (!h) { fprintf(stderr, "FindPatch failed: ptex %d (%g, %g)\n", face, u, v); return 1; }
        pt->EvaluateBasis(*h, u, v, w.data(), wu.data(), wv.data());
        Far::ConstIndexArray cv = pt->GetPatchVertices(*h);
        double P[3] = {0, 0, 0}, UV[2] = {0, 0};
        for (int k = 0; k < cv.size(); ++k) for (int c = 0; c < 3; ++c) P[c] += w[k] * pts[cv[k]].p[c];
        pt->EvaluateBasisFaceVarying(*h, u, v, w.data(), wu.data(), wv.data(), 0, 0, 0, 0);
        Far::ConstIndexArray cf = pt->GetPatchFVarValues(*h, 0);
        for (int k = 0; k < cf.size(); ++k) for (int c = 0; c < 2; ++c) UV[c] += w[k] * fv[cf[k]].p[c];
        // Where the truncation can happen, decided from the refiner's topology alone (the spilled writes land
        // on memory OpenSubdiv reads later: stencil sizes and even the face-varying patch params' regular bit
        // change from run to run, the UVs do not): a patch of an unrefined quad whose face has two adjacent
        // corners at UV seams or boundaries, under the rules that sharpen spans of more than one face (2-4).
        // This over-covers: some flagged samples match.
        double flag = 0;
        Far::PatchParam vp = pt->GetPatchParam(*h);
        if (cage.fvar_rule >= 2 && cage.fvar_rule <= 4 && vp.GetDepth() == 0 && cage.nv[vp.GetFaceId()] == 4) {
            Far::TopologyLevel const &l0 = r->GetLevel(0);
            Far::ConstIndexArray fverts = l0.GetFaceVertices(vp.GetFaceId());
            for (int k = 0; k < 4; ++k)
                if (!l0.DoesVertexFVarTopologyMatch(fverts[k], 0) && !l0.DoesVertexFVarTopologyMatch(fverts[(k + 1) % 4], 0))
                    flag = 1;
        }
        out.push_back(face); out.push_back(u); out.push_back(v);
        for (int c = 0; c < 3; ++c) out.push_back(P[c]);
        for (int c = 0; c < 2; ++c) out.push_back(UV[c]);
        out.push_back(flag);
    }
    FILE *fo = fopen(path, "wb");
    if (!fo) { fprintf(stderr, "cannot write %s\n", path); return 1; }
    uint32_t nn = n;
    fwrite(&nn, 4, 1, fo);
    fwrite(out.data(), 8, out.size(), fo);
    fclose(fo);
    fprintf(stderr, "%s: %d UV samples over %zu ptex faces (max level %d, %d local UV points, rule %d)\n", path, n,
            ptex_face.size(), r->GetMaxLevel(), nlocfv, cage.fvar_rule);
    delete pt; delete r;
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 3) { fprintf(stderr, "usage: %s IN.obj OUT.osd [--refine] [--f32] [--samples]\n", argv[0]); return 2; }
    bool refine = false, f32 = false, samples = false;
    const char *limit_path = 0;
    const char *ptex_path = 0;
    int ptex_n = 0, isolation = 0, fvar_n = 0;
    const char *fvar_path = 0;
    for (int i = 3; i < argc; ++i) {
        if (!strcmp(argv[i], "--limit") && i + 1 < argc) { limit_path = argv[++i]; continue; }
        if (!strcmp(argv[i], "--ptex") && i + 2 < argc) { ptex_n = atoi(argv[++i]); ptex_path = argv[++i]; continue; }
        if (!strcmp(argv[i], "--fvar") && i + 2 < argc) { fvar_n = atoi(argv[++i]); fvar_path = argv[++i]; continue; }
        if (!strcmp(argv[i], "--isolation") && i + 1 < argc) { isolation = atoi(argv[++i]); continue; }
        if (!strcmp(argv[i], "--faces") && i + 2 < argc) { g_face_lo = atoi(argv[++i]); g_face_hi = atoi(argv[++i]); continue; }
        if (!strcmp(argv[i], "--fd") && i + 1 < argc) { g_fd_path = argv[++i]; continue; }
        if (!strcmp(argv[i], "--refine")) refine = true;
        else if (!strcmp(argv[i], "--f32")) f32 = true;
        else if (!strcmp(argv[i], "--samples")) samples = true;
    }
    Cage cage = read_obj(argv[1]);
    if (ptex_path) return write_ptex_samples(cage, ptex_n, ptex_path, isolation);
    if (fvar_path) return write_fvar_samples(cage, fvar_n, fvar_path, isolation);
    if (refine) cage = refine_once(cage);
    for (int n : cage.nv) if (n != 4) { fprintf(stderr, "%s: not all-quad (use --refine)\n", argv[1]); return 1; }
    int nf = (int)cage.nv.size();
    if (limit_path) {
        Far::TopologyRefiner *lr = make_refiner(cage);
        std::vector<V3> P(cage.pos.size()), T1(cage.pos.size()), T2(cage.pos.size());
        Far::PrimvarRefinerReal<double> pr(*lr);
        V3 const *src = cage.pos.data();
        V3 *dp = P.data(), *d1 = T1.data(), *d2 = T2.data();
        pr.Limit(src, dp, d1, d2);
        FILE *fl = fopen(limit_path, "wb");
        if (!fl) { fprintf(stderr, "cannot write %s\n", limit_path); return 1; }
        for (size_t v = 0; v < P.size(); ++v) { fwrite(P[v].p, 8, 3, fl); fwrite(T1[v].p, 8, 3, fl); fwrite(T2[v].p, 8, 3, fl); }
        fclose(fl);
        delete lr;
    }

    Far::TopologyRefiner *r = make_refiner(cage);
    Far::PatchTableFactory::Options po(0);
    po.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_GREGORY_BASIS);
    po.useInfSharpPatch = true;
    po.SetPatchPrecision<double>();
    r->RefineAdaptive(po.GetRefineAdaptiveOptions());
    Far::PatchTable const *pt = Far::PatchTableFactory::Create(*r, po);

    int nref = r->GetNumVerticesTotal();
    int nloc = pt->GetNumLocalPoints();
    std::vector<V3> pts(nref + nloc);
    std::copy(cage.pos.begin(), cage.pos.end(), pts.begin());
    if (nloc) pt->GetLocalPointStencilTable<double>()->UpdateValues(pts.data(), pts.data() + nref);

    Far::PatchMap pm(*pt);
    double inv[4][4];
    bern_inverse(inv);
    std::vector<uint32_t> type(nf, 99);
    std::vector<double> out(nf * 60, 0.0);
    const int NS = samples ? 16 : 0;
    std::vector<double> smp((size_t)nf * NS * 11, 0.0);
    const double su[4] = {0.0, 1.0 / 3.0, 0.6, 1.0};
    int nreg = 0, ngreg = 0;
    for (int a = 0; a < pt->GetNumPatchArrays(); ++a) {
        Far::PatchDescriptor d = pt->GetPatchArrayDescriptor(a);
        for (int p = 0; p < pt->GetNumPatches(a); ++p) {
            Far::PatchParam pp = pt->GetPatchParam(a, p);
            int f = pp.GetFaceId();
            if (f < 0 || f >= nf || pp.GetDepth() != 0) { fprintf(stderr, "unexpected patch face %d depth %d\n", f, pp.GetDepth()); return 1; }
            Far::ConstIndexArray cv = pt->GetPatchVertices(a, p);
            if (d.GetType() == Far::PatchDescriptor::GREGORY_BASIS) {
                type[f] = 1; ++ngreg;
                for (int k = 0; k < 20; ++k) for (int c = 0; c < 3; ++c) out[f * 60 + k * 3 + c] = pts[cv[k]].p[c];
                // OpenSubdiv 3.5 mis-sizes some face-point rows next to darts: entries of one row spill
                // into the next, leaving rows whose weights do not sum to 1. Such a patch is type 3: its
                // corner and edge points are compared, its face points are not.
                auto const *lst = pt->GetLocalPointStencilTable<double>();
                for (int k = 0; k < 20; ++k) {
                    if (cv[k] < nref) continue;
                    auto st = lst->GetStencil(cv[k] - nref);
                    double sum = 0;
                    for (int j = 0; j < st.GetSize(); ++j) sum += st.GetWeights()[j];
                    if (fabs(sum - 1.0) > 1e-9) {
                        fprintf(stderr, "face %d: OpenSubdiv's point %d has weights summing to %.6f: face points not compared\n", f, k, sum);
                        type[f] = 3;
                    }
                }
            } else if (d.GetType() == Far::PatchDescriptor::REGULAR) {
                type[f] = 0; ++nreg;
            } else { fprintf(stderr, "unexpected patch type %d\n", (int)d.GetType()); return 1; }
        }
    }
    std::vector<double> w(20), wu(20), wv(20);
    // Tagged holes, and under VTX_BOUNDARY_NONE the boundary faces OpenSubdiv made holes.
    std::vector<char> hole(nf, 0);
    for (int f = 0; f < nf; ++f) hole[f] = r->GetLevel(0).IsFaceHole(f);
    for (int f = 0; f < nf; ++f) {
        if (hole[f]) {
            if (type[f] != 99) { fprintf(stderr, "hole face %d has a patch\n", f); return 1; }
            type[f] = 2;
            continue;
        }
        if (type[f] == 99) { fprintf(stderr, "face %d has no patch\n", f); return 1; }
        auto eval = [&](double u, double v, double P[3], double Du[3], double Dv[3]) {
            Far::PatchTable::PatchHandle const *h = pm.FindPatch(f, u, v);
            if (!h) { fprintf(stderr, "FindPatch failed face %d\n", f); exit(1); }
            pt->EvaluateBasis(*h, u, v, w.data(), wu.data(), wv.data());
            Far::ConstIndexArray cv = pt->GetPatchVertices(*h);
            for (int c = 0; c < 3; ++c) P[c] = Du[c] = Dv[c] = 0;
            for (int k = 0; k < cv.size(); ++k) for (int c = 0; c < 3; ++c) {
                P[c] += w[k] * pts[cv[k]].p[c]; Du[c] += wu[k] * pts[cv[k]].p[c]; Dv[c] += wv[k] * pts[cv[k]].p[c];
            }
        };
        if (type[f] == 0) {
            double X[4][4][3], T[4][4][3], B[4][4][3];
            for (int j = 0; j < 4; ++j) for (int i = 0; i < 4; ++i) {
                double du[3], dv[3];
                eval(i / 3.0, j / 3.0, X[j][i], du, dv);
            }
            // B = inv * X * inv^T (rows = v, cols = u)
            for (int j = 0; j < 4; ++j) for (int i = 0; i < 4; ++i) for (int c = 0; c < 3; ++c) {
                double s = 0; for (int k = 0; k < 4; ++k) s += inv[j][k] * X[k][i][c]; T[j][i][c] = s;
            }
            for (int j = 0; j < 4; ++j) for (int i = 0; i < 4; ++i) for (int c = 0; c < 3; ++c) {
                double s = 0; for (int k = 0; k < 4; ++k) s += T[j][k][c] * inv[i][k]; B[j][i][c] = s;
            }
            for (int j = 0; j < 4; ++j) for (int i = 0; i < 4; ++i) for (int h = 0; h < 2; ++h)
                for (int c = 0; c < 3; ++c) out[f * 60 + GRID[j][i][h] * 3 + c] = B[j][i][c];
        }
        for (int s = 0; s < NS; ++s) {
            double u = su[s % 4], v = su[s / 4];
            double *o = &smp[((size_t)f * NS + s) * 11];
            o[0] = u; o[1] = v;
            eval(u, v, o + 2, o + 5, o + 8);
        }
    }

    FILE *fo = fopen(argv[2], "wb");
    if (!fo) { fprintf(stderr, "cannot write %s\n", argv[2]); return 1; }
    fwrite("GVOSD001", 1, 8, fo);
    uint32_t hdr[4] = {(uint32_t)cage.pos.size(), (uint32_t)nf, f32 ? 4u : 8u, (uint32_t)NS};
    fwrite(hdr, 4, 4, fo);
    for (auto &v : cage.pos) fwrite(v.p, 8, 3, fo);
    uint32_t acc = 0;
    fwrite(&acc, 4, 1, fo);
    for (int n : cage.nv) { acc += n; fwrite(&acc, 4, 1, fo); }
    for (int i : cage.idx) { uint32_t u = i; fwrite(&u, 4, 1, fo); }
    fwrite(type.data(), 4, nf, fo);
    if (f32) { std::vector<float> o(out.begin(), out.end()); fwrite(o.data(), 4, o.size(), fo); }
    else fwrite(out.data(), 8, out.size(), fo);
    fwrite(smp.data(), 8, smp.size(), fo);
    fclose(fo);
    fprintf(stderr, "%s: %zu verts, %d quads, %d regular, %d gregory, %d local points\n", argv[2], cage.pos.size(), nf, nreg, ngreg, nloc);
    delete pt;
    delete r;
    return 0;
}
