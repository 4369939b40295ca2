// The body of the Gregory evaluation kernels, uniform (gregory_eval.comp) and adaptive
// (gregory_eval_adaptive.comp, which defines GREGORY_ADAPTIVE). A workgroup evaluates pc.patches_per_group
// patches in turn (1 on GPUs; up to 8 at low levels on CPU devices, where each workgroup has a fixed cost):
// for each it stages the patch's 20 control points in shared memory once (gathered through patch_points),
// then its 8 invocations stride over the patch's vertices. gregory_eval_subgroup.comp orders the staging
// with a subgroup barrier where one subgroup holds the workgroup (llvmpipe: 1.6× at level 4 with both). Measured on llvmpipe (spot, 2,928 patches): every invocation pays a per-patch set-up
// of ~1.5 µs before its vertex loop (cause inside llvmpipe not isolated), so the workgroup is one subgroup —
// at L = 32 37.5 M vertices/s against 13.6 M/s with 64 invocations (L = 16: 28.6 vs 6.6 M/s). One invocation
// per vertex with 20 indirect loads each ran at 0.4–2.5 M vertices/s (the gathers dominated). On a GPU with
// 32- or 64-wide subgroups GROUP_SIZE (gregory_eval.rs) should be raised. The evaluation runs in patch-local
// coordinates (points − s_cv[0], see gregory.glsl); edge points use the world-space shared copy. Positions
// and unit normals go to a device-local buffer that the graphics pipeline then draws as a vertex buffer
// (stride 32: vec4 position, vec4 normal).
//
// Uniform: vertex patch·(L+1)² + j·(L+1) + i at (u, v) = (i/L, j/L).
// Adaptive: patch p has its own level L_p (levels[p]) and its grid fills the first (L_p+1)² vertices of its
// fixed slot of (L_max+1)²: vertex p·(L_max+1)² + j·(L_p+1) + i. Edge e of the patch has the level
// L_e = min over the patches sharing it (edge_levels[edge_ids[4p+e]]); every vertex of the boundary row is
// SNAPPED to the nearest of the edge's L_e+1 samples, k = round(i·L_e/L_p), evaluated canonically. Since
// L_e ≤ L_p the snapped row visits every sample in order (steps of at most one), so both patches of an edge
// produce the same polyline: no cracks, no T-junctions, only zero-area triangles where samples repeat.
//
// Vertices on a patch edge are evaluated from the edge's four boundary points only, in the edge's canonical
// direction (from the lower cage vertex to the higher, flag bit e of patch_flags) with t from the canonical
// integer index: both patches of an edge produce bit-identical positions (no cracks).
#ifdef GREGORY_SUBGROUP_BARRIER
// The workgroup is one subgroup (gregory_eval.rs picks this variant only when the device's subgroups are at
// least GROUP_SIZE wide): a subgroup barrier orders the shared-memory staging, and on llvmpipe it costs far
// less than a workgroup barrier (~25 % of the kernel at level 4).
#extension GL_KHR_shader_subgroup_basic : require
#define GREGORY_BARRIER() subgroupBarrier()
#else
#define GREGORY_BARRIER() barrier()
#endif
#include "gregory.glsl"
layout(local_size_x = 8) in;    // gregory_eval.rs GROUP_SIZE
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(std430, set = 0, binding = 2) readonly buffer PatchFlags { uint patch_flags[]; };
#include "surface_vertex.glsl"
layout(std430, set = 0, binding = 3) writeonly buffer Vertices { Vertex vertices[]; };
#ifdef GREGORY_ADAPTIVE
layout(std430, set = 0, binding = 4) readonly buffer Levels { uint levels[]; };
layout(std430, set = 0, binding = 5) readonly buffer EdgeIds { uint edge_ids[]; };
layout(std430, set = 0, binding = 6) readonly buffer EdgeLevels { uint edge_levels[]; };
#endif
layout(push_constant) uniform Push {
    uint patch_count;  // in this dispatch
    uint level;        // L (uniform) or L_max (adaptive: the slot size)
    uint canonical;    // 1: canonical edge evaluation on
    uint residual_rows;  // > 0: point r's f32 residual is points[residual_rows + r] (gregory_points.comp)
    uint patch_base;     // this dispatch's first patch: `vertices` is bound from its slot on (a batch fits
                         // one storage binding, gregory_eval.rs patch_batches)
    uint patches_per_group;  // patches evaluated one after the other by each workgroup (≥ 1)
} pc;

shared vec3 s_cv[20];   // the patch's control points, world coordinates
shared vec3 s_lo[20];   // their residuals (zero without)

// The four boundary points of edge e, parameter increasing with u (edges 0, 2) or v (edges 1, 3). Constant
// indices only: a dynamic index into cv[] can make llvmpipe keep the whole array in per-lane memory.
// The points come from the workgroup's shared copy (world coordinates, the same bits in both patches of an
// edge), so no per-invocation world-space array stays alive next to the patch-local one.
void edge_cubic(int e, out vec3 a, out vec3 b, out vec3 c, out vec3 d) {
    if (e == 0) { a = s_cv[0]; b = s_cv[1]; c = s_cv[7]; d = s_cv[5]; }
    else if (e == 1) { a = s_cv[5]; b = s_cv[6]; c = s_cv[12]; d = s_cv[10]; }
    else if (e == 2) { a = s_cv[15]; b = s_cv[17]; c = s_cv[11]; d = s_cv[10]; }
    else { a = s_cv[0]; b = s_cv[2]; c = s_cv[16]; d = s_cv[15]; }
}

vec3 edge_point(uint flags, int e, uint n, uint L) {
    bool reversed = ((flags >> uint(e)) & 1u) == 1u;
    vec3 a, b, c, d;
    edge_cubic(e, a, b, c, d);
    if (reversed) {
        float t = float(L - n) / float(L);
        return gregory_edge(d, c, b, a, t);
    }
    float t = float(n) / float(L);
    return gregory_edge(a, b, c, d, t);
}

// Nearest of the L_e + 1 edge samples to sample n of L (ties round up; L_e ≤ L).
uint snap(uint n, uint L, uint le) {
    return (2u * n * le + L) / (2u * L);
}


// Evaluates patch `batch_patch` of this dispatch with the workgroup's invocation t.
void evaluate_patch(uint batch_patch, uint t) {
    uint patch_id = pc.patch_base + batch_patch;
    for (uint k = t; k < 20u; k += gl_WorkGroupSize.x) {
        uint row = patch_points[20u * patch_id + k];
        s_cv[k] = points[row].xyz;
        s_lo[k] = pc.residual_rows > 0u ? points[pc.residual_rows + row].xyz : vec3(0.0);
    }
    GREGORY_BARRIER();
#ifdef GREGORY_ADAPTIVE
    uint L = levels[patch_id];
    uint base = batch_patch * (pc.level + 1u) * (pc.level + 1u);
#else
    uint L = pc.level;
    uint base = batch_patch * (L + 1u) * (L + 1u);
#endif
    uint per_patch = (L + 1u) * (L + 1u);
    // Invocations without a vertex leave this patch before its set-up (the next barrier is main's, which
    // every invocation reaches).
    if (t >= per_patch) return;
#ifdef GREGORY_ADAPTIVE
    uvec4 le = uvec4(edge_levels[edge_ids[4u * patch_id]], edge_levels[edge_ids[4u * patch_id + 1u]],
                     edge_levels[edge_ids[4u * patch_id + 2u]], edge_levels[edge_ids[4u * patch_id + 3u]]);
#endif
    // Patch-local points (hi_k − hi_0) + (lo_k − lo_0): the world-space rounding of the points cancels, what
    // is left scales with the patch size (see gregory_points.comp and gregory_localize).
    vec3 origin = s_cv[0], lcv[20];
    for (int k = 0; k < 20; ++k) lcv[k] = (s_cv[k] - origin) + (s_lo[k] - s_lo[0]);
    uint flags = patch_flags[patch_id];
    for (uint local = t; local < per_patch; local += gl_WorkGroupSize.x) {
        uint j = local / (L + 1u);
        uint i = local - j * (L + 1u);
        float u = float(i) / float(L);
        float v = float(j) / float(L);
        // Boundary rows: which edge (-1: interior) and the sample index n of m along it.
        int edge = -1;
        uint n = 0u, m = L;
        if (pc.canonical == 1u) {
            if (j == 0u) { edge = 0; n = i; }
            else if (j == L) { edge = 2; n = i; }
            else if (i == 0u) { edge = 3; n = j; }
            else if (i == L) { edge = 1; n = j; }
        }
#ifdef GREGORY_ADAPTIVE
        if (edge >= 0) {
            m = edge == 0 ? le.x : edge == 1 ? le.y : edge == 2 ? le.z : le.w;
            n = snap(n, L, m);
            float s = float(n) / float(m);
            if (edge == 0 || edge == 2) u = s; else v = s;
        }
#endif
        vec3 p, su, sv;
        vec3 net[16];
        gregory_eval_local(lcv, origin, u, v, p, su, sv, net);
        vec3 nrm = gregory_normal(net, su, sv, u, v);
        if (edge >= 0) p = edge_point(flags, edge, n, m);
        vertices[base + local].position = vec4(p, 1.0);
        vertices[base + local].normal = vec4(nrm, 0.0);
    }
}

void main() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint t = gl_LocalInvocationIndex;
    // patches_per_group > 1 at low levels on CPU devices: the per-workgroup cost is paid once for several
    // patches (gregory_eval.rs patches_per_group).
    for (uint q = 0u; q < pc.patches_per_group; ++q) {
        uint batch_patch = group * pc.patches_per_group + q;
        if (batch_patch >= pc.patch_count) return;   // uniform across the workgroup
        if (q > 0u) GREGORY_BARRIER();   // every invocation is done with the previous patch's shared points
        evaluate_patch(batch_patch, t);
    }
}
