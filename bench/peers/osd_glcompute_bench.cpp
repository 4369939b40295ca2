// OpenSubdiv GPU peer for `gregvox bench` (suite `gregory`): the same-device peer of osd_eval_bench.cpp.
// It evaluates the same samples gregvox evaluates — every face of an all-quad cage, (level+1)^2 samples on
// the uniform grid u,v = i/level (face-major, then j, then i), position and both first derivatives — with
// Osd::GLComputeEvaluator::EvalPatches (OpenGL 4.3 compute shaders, float) on the patch table built exactly
// as osd_eval_bench.cpp and tests/oracle/osd_gregory.cpp build it (isolation 0, CATMARK,
// VTX_BOUNDARY_EDGE_ONLY, ENDCAP_GREGORY_BASIS), float precision like osd_eval_bench's `omp_median_s` path.
// The OpenGL 4.3+ core context has no window: EGL (surfaceless platform when Mesa offers it, otherwise the
// default display) with EGL_NO_SURFACE. On a machine without a GPU, Mesa's llvmpipe runs it on the CPU.
//
// Timed (median of REPEATS after one warm-up run): `median_s` = EvalPatches (one dispatch per chunk, see
// `dispatches`) + glFinish(), wall clock (std::chrono); `gpu_median_s` = the same runs measured on the GL
// clock, glQueryCounter(GL_TIMESTAMP) before the first EvalPatches and after the last; `elapsed_median_s` =
// a GL_TIME_ELAPSED query around the same commands (null where the driver lacks the query). On llvmpipe
// (Mesa 22) GL_TIME_ELAPSED does not count compute dispatches (it reads ~1e-9 s), hence the timestamps.
// Not timed: the EGL/GL context, the patch tables and the local (Gregory basis) points, the source buffer
// upload (Osd::GLVertexBuffer), Osd::GLPatchTable, the shader compilation (GLComputeEvaluator::Create) and
// the patch coordinates (Far::PatchMap::FindPatch, uploaded once per level), i.e. what an application that
// re-evaluates a fixed sampling builds once — like gregvox's stencils and W·cage.
// Checked after timing: the positions are read back once and compared with a CPU evaluation of the same
// samples (Far::PatchTable::EvaluateBasis in double, as osd_eval_bench.cpp's `median_s` loop does):
// `max_abs_diff_cpu` (positions), `max_abs_diff_cpu_deriv` (du, dv).
//
// GL loading: OpenSubdiv 3.5's libosdGPU carries its own GL loader (internal::GLLoader, initialised by the
// first GLVertexBuffer / GLPatchTable / GLComputeEvaluator; it dlopens libGL.so.1 and resolves through
// glXGetProcAddressARB, which glvnd dispatches to the EGL context current here), so no GLEW; this file's own
// few GL calls link against glvnd's libOpenGL.
//
// Limits: one EvalPatches dispatch covers at most GL_MAX_COMPUTE_WORK_GROUP_COUNT[0] * 64 samples (the
// evaluator's work group is 64; llvmpipe: 65535 * 64 = 4,194,240) and GL_MAX_SHADER_STORAGE_BLOCK_SIZE / 20
// samples (20-byte patch coordinates; llvmpipe: 128 MiB / 20 = 6.7 M); more samples are split into chunks, each with its own coordinate and output
// buffers (`dispatches` > 1). Each chunk's buffers are padded to a multiple of 64 samples (the kernel has no
// bounds check).
//
// Environment: none needed with Mesa — the surfaceless platform falls back to swrast (llvmpipe) when there
// is no DRM device (EGL_LOG_LEVEL=debug shows the choice); LIBGL_ALWAYS_SOFTWARE=1 forces llvmpipe elsewhere.
//
// Build: c++ -O2 -std=c++14 -o osd_glcompute_bench osd_glcompute_bench.cpp -losdGPU -losdCPU -lEGL -lOpenGL
//        (bench/peers/install.sh; apt: libosd-dev libegl-dev libopengl-dev libgl1 libegl-mesa0 libgl1-mesa-dri)
// Usage: osd_glcompute_bench CAGE.obj REPEATS LEVEL...
// Output: one JSON object per level on stdout:
//   {"level": L, "patches": F, "vertices": F*(L+1)^2, "median_s": S, "gpu_median_s": S,
//    "elapsed_median_s": S, "dispatches": K,
//    "renderer": "GL_RENDERER", "version": "GL_VERSION", "checksum": C, "cpu_checksum": C,
//    "max_abs_diff_cpu": D, "max_abs_diff_cpu_deriv": D}
// Errors: one line on stderr, exit 1 (exit 2 for a wrong command line).
#define GL_GLEXT_PROTOTYPES 1
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <opensubdiv/far/error.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/osd/opengl.h>
#include <opensubdiv/osd/glVertexBuffer.h>
#include <opensubdiv/osd/glPatchTable.h>
#include <opensubdiv/osd/glComputeEvaluator.h>
#include <GL/glext.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "osd_cage.h"

using namespace OpenSubdiv;

static_assert(sizeof(Osd::PatchCoord) == 5 * sizeof(float), "the GPU reads PatchCoord as 5 x 4 bytes");

static const int kWorkGroup = 64;  // Osd::GLComputeEvaluator's work group size (fixed in its constructor)

static double median(std::vector<double> t) {
    std::sort(t.begin(), t.end());
    size_t m = t.size();
    return m % 2 ? t[m / 2] : 0.5 * (t[m / 2 - 1] + t[m / 2]);
}

static std::string json_escape(const char *s) {
    std::string o;
    for (; s && *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') { o += '\\'; o += (char)c; }
        else if (c < 0x20) { char b[8]; snprintf(b, sizeof b, "\\u%04x", c); o += b; }
        else o += (char)c;
    }
    return o;
}

static void far_error_to_stderr(Far::ErrorType, const char *message) { fprintf(stderr, "OpenSubdiv: %s\n", message); }

static bool has_ext(const char *list, const char *name) {
    if (!list) return false;
    size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)); p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

// An OpenGL 4.5 (else 4.3) core context current with no surface. On failure: one stderr line, false.
static bool make_context(EGLDisplay *out_dpy, EGLContext *out_ctx) {
    const char *cext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);  // client extensions (may be NULL)
    EGLDisplay dpy = EGL_NO_DISPLAY;
    const char *how = "eglGetDisplay(EGL_DEFAULT_DISPLAY)";
    if (has_ext(cext, "EGL_MESA_platform_surfaceless") && has_ext(cext, "EGL_EXT_platform_base")) {
        PFNEGLGETPLATFORMDISPLAYEXTPROC gpd =
            (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
        if (gpd) {
            dpy = gpd(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
            how = "eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA)";
        }
    }
    if (dpy == EGL_NO_DISPLAY) dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    if (dpy == EGL_NO_DISPLAY) { fprintf(stderr, "%s failed (EGL error 0x%x)\n", how, eglGetError()); return false; }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor)) {
        fprintf(stderr, "eglInitialize failed after %s (EGL error 0x%x)\n", how, eglGetError());
        return false;
    }
    const char *dext = eglQueryString(dpy, EGL_EXTENSIONS);
    if (!has_ext(dext, "EGL_KHR_surfaceless_context")) {
        fprintf(stderr, "eglQueryString: the EGL display lacks EGL_KHR_surfaceless_context\n");
        return false;
    }
    if (!eglBindAPI(EGL_OPENGL_API)) { fprintf(stderr, "eglBindAPI(EGL_OPENGL_API) failed (EGL error 0x%x)\n", eglGetError()); return false; }
    EGLConfig cfg = (EGLConfig)0;  // EGL_NO_CONFIG_KHR
    if (!has_ext(dext, "EGL_KHR_no_config_context")) {
        const EGLint ca[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
        EGLint n = 0;
        if (!eglChooseConfig(dpy, ca, &cfg, 1, &n) || n < 1) {
            fprintf(stderr, "eglChooseConfig found no EGL_OPENGL_BIT config (EGL error 0x%x)\n", eglGetError());
            return false;
        }
    }
    EGLContext ctx = EGL_NO_CONTEXT;
    for (int want_minor : {5, 3}) {
        const EGLint attr[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, want_minor,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
        ctx = eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, attr);
        if (ctx != EGL_NO_CONTEXT) break;
    }
    if (ctx == EGL_NO_CONTEXT) {
        fprintf(stderr, "eglCreateContext (OpenGL 4.5 / 4.3 core) failed (EGL error 0x%x)\n", eglGetError());
        return false;
    }
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        fprintf(stderr, "eglMakeCurrent(EGL_NO_SURFACE) failed (EGL error 0x%x)\n", eglGetError());
        return false;
    }
    *out_dpy = dpy;
    *out_ctx = ctx;
    return true;
}

static void read_buffer(Osd::GLVertexBuffer *b, size_t floats, float *dst) {
    glBindBuffer(GL_COPY_READ_BUFFER, b->BindVBO());
    glGetBufferSubData(GL_COPY_READ_BUFFER, 0, (GLsizeiptr)(floats * sizeof(float)), dst);
    glBindBuffer(GL_COPY_READ_BUFFER, 0);
}

int main(int argc, char **argv) {
    if (argc < 4) { fprintf(stderr, "usage: %s CAGE.obj REPEATS LEVEL...\n", argv[0]); return 2; }
    Far::SetErrorCallback(far_error_to_stderr);  // keep stdout for the JSON lines
    std::vector<V3> pos;
    std::vector<int> nv, idx;
    if (!read_quad_cage(argv[1], pos, nv, idx)) return 1;
    int repeats = std::max(1, atoi(argv[2]));
    for (int a = 3; a < argc; ++a)
        if (atoi(argv[a]) < 1) { fprintf(stderr, "level %s is not positive\n", argv[a]); return 1; }

    GregoryTables t;
    if (!make_gregory_tables(argv[1], pos, nv, idx, t)) return 1;
    const int nf = (int)nv.size();
    // The float path of Osd (as osd_eval_bench.cpp's): the float patch table and its points as x, y, z floats.
    const Far::PatchTable *ptf = t.ptf.get();
    const std::vector<V3f> &srcv = t.ptsf;

    EGLDisplay dpy;
    EGLContext ctx;
    if (!make_context(&dpy, &ctx)) return 1;
    GLint glmaj = 0, glmin = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &glmaj);
    glGetIntegerv(GL_MINOR_VERSION, &glmin);
    if (glmaj * 10 + glmin < 43) { fprintf(stderr, "the context is OpenGL %d.%d, compute needs 4.3\n", glmaj, glmin); return 1; }
    const std::string renderer = json_escape((const char *)glGetString(GL_RENDERER));
    const std::string version = json_escape((const char *)glGetString(GL_VERSION));
    GLint max_groups = 0;
    glGetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, 0, &max_groups);
    GLint64 max_block = 0;
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &max_block);
    GLint elapsed_bits = 0, stamp_bits = 0;
    glGetQueryiv(GL_TIME_ELAPSED, GL_QUERY_COUNTER_BITS, &elapsed_bits);
    glGetQueryiv(GL_TIMESTAMP, GL_QUERY_COUNTER_BITS, &stamp_bits);
    // Samples one dispatch may cover: the work group count and the largest bound block (20 B coordinates).
    long long cap = std::min((long long)max_groups * kWorkGroup, (long long)(max_block / (GLint64)sizeof(Osd::PatchCoord)));
#ifdef OSD_GLCOMPUTE_MAX_CHUNK  // test hook: -DOSD_GLCOMPUTE_MAX_CHUNK=N exercises the chunked path
    cap = std::min(cap, (long long)OSD_GLCOMPUTE_MAX_CHUNK);
#endif
    cap = std::min(cap, (long long)1 << 30) / kWorkGroup * kWorkGroup;
    if (cap < kWorkGroup) { fprintf(stderr, "GL limits too small (work groups %d, SSBO block %lld B)\n", max_groups, (long long)max_block); return 1; }

    const int nsrc = (int)srcv.size();
    Osd::GLVertexBuffer *src = Osd::GLVertexBuffer::Create(3, nsrc);
    if (!src) { fprintf(stderr, "Osd::GLVertexBuffer::Create (source) failed\n"); return 1; }
    src->UpdateData(&srcv[0].p[0], 0, nsrc);
    Osd::GLPatchTable *gpt = Osd::GLPatchTable::Create(ptf);
    if (!gpt) { fprintf(stderr, "Osd::GLPatchTable::Create failed\n"); return 1; }
    Osd::BufferDescriptor srcDesc(0, 3, 3), dstDesc(0, 3, 3), duDesc(0, 3, 3), dvDesc(0, 3, 3);
    Osd::GLComputeEvaluator *evaluator = Osd::GLComputeEvaluator::Create(srcDesc, dstDesc, duDesc, dvDesc);
    if (!evaluator) { fprintf(stderr, "Osd::GLComputeEvaluator::Create failed (compute shader did not compile/link)\n"); return 1; }
    if (GLenum e = glGetError()) { fprintf(stderr, "OpenGL error 0x%x while building the GL buffers\n", e); return 1; }
    GLuint elapsed_q = 0, stamp_q[2] = {0, 0};
    if (elapsed_bits > 0) glGenQueries(1, &elapsed_q);
    if (stamp_bits > 0) glGenQueries(2, stamp_q);

    for (int a = 3; a < argc; ++a) {
        int L = atoi(argv[a]);
        size_t n = (size_t)nf * (L + 1) * (L + 1);
        std::vector<Osd::PatchCoord> coords;
        if (!patch_coords(t, L, coords)) return 1;
        // Chunks of at most `cap` samples, each with its own buffers padded to a multiple of the work group.
        struct Chunk { size_t start, count; Osd::GLVertexBuffer *pc, *P, *Du, *Dv; };
        std::vector<Chunk> chunks;
        for (size_t s = 0; s < n; s += (size_t)cap) {
            Chunk c;
            c.start = s;
            c.count = std::min((size_t)cap, n - s);
            size_t padded = (c.count + kWorkGroup - 1) / kWorkGroup * kWorkGroup;
            std::vector<Osd::PatchCoord> pcv(coords.begin() + s, coords.begin() + s + c.count);
            pcv.resize(padded, coords[s]);  // the padding evaluates a real sample, written past `count`
            c.pc = Osd::GLVertexBuffer::Create(5, (int)padded);
            c.P = Osd::GLVertexBuffer::Create(3, (int)padded);
            c.Du = Osd::GLVertexBuffer::Create(3, (int)padded);
            c.Dv = Osd::GLVertexBuffer::Create(3, (int)padded);
            if (!c.pc || !c.P || !c.Du || !c.Dv) { fprintf(stderr, "Osd::GLVertexBuffer::Create failed at level %d\n", L); return 1; }
            c.pc->UpdateData(reinterpret_cast<const float *>(pcv.data()), 0, (int)padded);
            chunks.push_back(c);
        }
        if (GLenum e = glGetError()) { fprintf(stderr, "OpenGL error 0x%x uploading level %d (%zu samples)\n", e, L, n); return 1; }
        glFinish();

        bool ok = true;
        std::vector<double> wall, gpu, elapsed;
        for (int rep = 0; rep < repeats + 1; ++rep) {
            if (elapsed_q) glBeginQuery(GL_TIME_ELAPSED, elapsed_q);
            if (stamp_q[0]) glQueryCounter(stamp_q[0], GL_TIMESTAMP);
            auto t0 = std::chrono::steady_clock::now();
            for (const Chunk &c : chunks)
                ok = ok && Osd::GLComputeEvaluator::EvalPatches(src, srcDesc, c.P, dstDesc, c.Du, duDesc, c.Dv, dvDesc,
                                                                (int)c.count, c.pc, gpt, evaluator);
            if (stamp_q[1]) glQueryCounter(stamp_q[1], GL_TIMESTAMP);
            if (elapsed_q) glEndQuery(GL_TIME_ELAPSED);
            glFinish();
            auto t1 = std::chrono::steady_clock::now();
            if (rep == 0) {
                if (GLenum e = glGetError()) { fprintf(stderr, "OpenGL error 0x%x in EvalPatches at level %d\n", e, L); return 1; }
                continue;
            }
            wall.push_back(std::chrono::duration<double>(t1 - t0).count());
            if (stamp_q[0]) {
                GLuint64 s0 = 0, s1 = 0;
                glGetQueryObjectui64v(stamp_q[0], GL_QUERY_RESULT, &s0);
                glGetQueryObjectui64v(stamp_q[1], GL_QUERY_RESULT, &s1);
                gpu.push_back((double)(s1 - s0) * 1e-9);
            }
            if (elapsed_q) {
                GLuint64 ns = 0;
                glGetQueryObjectui64v(elapsed_q, GL_QUERY_RESULT, &ns);
                elapsed.push_back((double)ns * 1e-9);
            }
        }
        if (!ok) { fprintf(stderr, "GLComputeEvaluator::EvalPatches failed at level %d\n", L); return 1; }

        // Read back once, compare with the CPU evaluation of the same samples.
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        std::vector<float> P(n * 3), Du(n * 3), Dv(n * 3);
        for (const Chunk &c : chunks) {
            read_buffer(c.P, c.count * 3, &P[c.start * 3]);
            read_buffer(c.Du, c.count * 3, &Du[c.start * 3]);
            read_buffer(c.Dv, c.count * 3, &Dv[c.start * 3]);
        }
        if (GLenum e = glGetError()) { fprintf(stderr, "OpenGL error 0x%x reading back level %d\n", e, L); return 1; }
        double diff = 0, diff_d = 0, checksum = 0, cpu_checksum = 0;
        size_t k = 0;
        for (int f = 0; f < nf; ++f)
            for (int j = 0; j <= L; ++j)
                for (int i = 0; i <= L; ++i, ++k) {
                    double cp[3], cu[3], cv[3];
                    if (!cpu_sample(t, f, (double)i / L, (double)j / L, cp, cu, cv)) {
                        fprintf(stderr, "FindPatch failed face %d\n", f);
                        return 1;
                    }
                    for (int e = 0; e < 3; ++e) {
                        diff = std::max(diff, std::fabs((double)P[k * 3 + e] - cp[e]));
                        diff_d = std::max(diff_d, std::max(std::fabs((double)Du[k * 3 + e] - cu[e]),
                                                           std::fabs((double)Dv[k * 3 + e] - cv[e])));
                    }
                    if (k % 97 == 0) { checksum += P[k * 3]; cpu_checksum += (float)cp[0]; }
                }
        if (!std::isfinite(diff) || !std::isfinite(diff_d)) diff = diff_d = INFINITY;
        char gpu_s[32], elapsed_s[32];
        if (gpu.empty()) snprintf(gpu_s, sizeof gpu_s, "null");
        else snprintf(gpu_s, sizeof gpu_s, "%.9g", median(gpu));
        if (elapsed.empty()) snprintf(elapsed_s, sizeof elapsed_s, "null");
        else snprintf(elapsed_s, sizeof elapsed_s, "%.9g", median(elapsed));
        printf("{\"level\": %d, \"patches\": %d, \"vertices\": %zu, \"median_s\": %.9g, \"gpu_median_s\": %s, "
               "\"elapsed_median_s\": %s, \"dispatches\": %zu, \"renderer\": \"%s\", \"version\": \"%s\", \"checksum\": %.9g, "
               "\"cpu_checksum\": %.9g, \"max_abs_diff_cpu\": %.3g, \"max_abs_diff_cpu_deriv\": %.3g}\n",
               L, nf, n, median(wall), gpu_s, elapsed_s, chunks.size(), renderer.c_str(), version.c_str(), checksum,
               cpu_checksum, diff, diff_d);
        fflush(stdout);
        for (Chunk &c : chunks) { delete c.pc; delete c.P; delete c.Du; delete c.Dv; }
    }
    if (elapsed_q) glDeleteQueries(1, &elapsed_q);
    if (stamp_q[0]) glDeleteQueries(2, stamp_q);
    delete evaluator;
    delete gpt;
    delete src;
    eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(dpy, ctx);
    eglTerminate(dpy);
    return 0;
}
