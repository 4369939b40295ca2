#version 460
// Evaluates every Gregory patch on its (L+1)² grid: one workgroup per patch stages the patch's 20 control
// points in shared memory once (gathered through patch_points), then its 64 invocations stride over the
// patch's vertices, vertex patch·(L+1)² + j·(L+1) + i at (u, v) = (i/L, j/L). (One invocation per vertex with
// 20 indirect loads each ran at 2.5 M vertices/s on llvmpipe: the gathers, not the arithmetic, dominated.) Positions and unit normals go to a device-local buffer
// that the graphics pipeline then draws as a vertex buffer (stride 32: vec4 position, vec4 normal).
// Vertices on a patch edge are evaluated from the edge's four boundary points only, in the edge's canonical
// direction (from the lower cage vertex to the higher, flag bit e of patch_flags) with t from the canonical
// integer index: both patches of an edge produce bit-identical positions (no cracks).
#include "gregory.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(std430, set = 0, binding = 2) readonly buffer PatchFlags { uint patch_flags[]; };
struct Vertex { vec4 position; vec4 normal; };
layout(std430, set = 0, binding = 3) writeonly buffer Vertices { Vertex vertices[]; };
layout(push_constant) uniform Push {
    uint patch_count;
    uint level;        // L
    uint canonical;    // 1: canonical edge evaluation on
    uint pad;
} pc;

// Boundary point lists per edge, parameter increasing with u (edges 0, 2) or v (edges 1, 3).
const int EDGE_POINTS[16] = int[16](0, 1, 7, 5,  5, 6, 12, 10,  15, 17, 11, 10,  0, 2, 16, 15);

vec3 edge_point(in vec3 cv[20], uint flags, int e, uint n, uint L) {
    bool reversed = ((flags >> uint(e)) & 1u) == 1u;
    int b = 4 * e;
    if (reversed) {
        float t = float(L - n) / float(L);
        return gregory_edge(cv[EDGE_POINTS[b + 3]], cv[EDGE_POINTS[b + 2]], cv[EDGE_POINTS[b + 1]],
                            cv[EDGE_POINTS[b]], t);
    }
    float t = float(n) / float(L);
    return gregory_edge(cv[EDGE_POINTS[b]], cv[EDGE_POINTS[b + 1]], cv[EDGE_POINTS[b + 2]],
                        cv[EDGE_POINTS[b + 3]], t);
}

shared vec3 s_cv[20];
void evaluate_vertex(in vec3 cv[20], uint flags, uint id, uint local, uint L);

void main() {
    uint L = pc.level;
    uint per_patch = (L + 1u) * (L + 1u);
    uint patch_id = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (patch_id >= pc.patch_count) return;   // uniform across the workgroup
    uint t = gl_LocalInvocationIndex;
    if (t < 20u) s_cv[t] = points[patch_points[20u * patch_id + t]].xyz;
    barrier();
    vec3 cv[20];
    for (int k = 0; k < 20; ++k) cv[k] = s_cv[k];
    uint flags = patch_flags[patch_id];
    for (uint local = t; local < per_patch; local += gl_WorkGroupSize.x) {
        evaluate_vertex(cv, flags, patch_id * per_patch + local, local, L);
    }
}

void evaluate_vertex(in vec3 cv[20], uint flags, uint id, uint local, uint L) {
    uint j = local / (L + 1u);
    uint i = local - j * (L + 1u);
    float u = float(i) / float(L);
    float v = float(j) / float(L);
    vec3 p, su, sv;
    vec3 net[16];
    gregory_eval(cv, u, v, p, su, sv, net);
    vec3 n = gregory_normal(net, su, sv, u, v);
    if (pc.canonical == 1u) {
        if (j == 0u) p = edge_point(cv, flags, 0, i, L);
        else if (j == L) p = edge_point(cv, flags, 2, i, L);
        else if (i == 0u) p = edge_point(cv, flags, 3, j, L);
        else if (i == L) p = edge_point(cv, flags, 1, j, L);
    }
    vertices[id].position = vec4(p, 1.0);
    vertices[id].normal = vec4(n, 0.0);
}
