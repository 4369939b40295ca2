// The vertex-pull path (the Beziex seed's instanced grid): one instance per patch, one static (L+1)² grid of
// vertex indices; the vertex shader evaluates its patch at (i/L, j/L) straight from a storage buffer.
// kind 0: Gregory (20 point indices per patch into `points`, residuals at mode.w + row when mode.w > 0), kind 1: Beziex (56 points per patch in `points`).
// With CAPTURE defined (patch_pull_capture.vert; needs vertexPipelineStoresAndAtomics) it also writes each
// evaluated vertex to `captured` in the compute path's order, so tests compare the two paths.
#include "surface_common.glsl"
#include "gregory.glsl"
#include "beziex.glsl"
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
#ifdef CAPTURE
#include "surface_vertex.glsl"
layout(std430, set = 0, binding = 2) writeonly buffer Captured { Vertex captured[]; };
#endif
layout(location = 0) out vec3 world_pos;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 patch_uv;
void main() {
    uint L = pc.mode.y;
    uint kind = pc.mode.z;
    uint n = L + 1u;
    uint i = uint(gl_VertexIndex) % n, j = uint(gl_VertexIndex) / n;
    uint patch_id = uint(gl_InstanceIndex);
    float u = float(i) / float(L), v = float(j) / float(L);
    vec3 p, nrm;
    if (kind == 0u) {
        // Patch-local points with the residuals of gregory_points.comp when mode.w > 0 (as gregory_eval).
        uint lo_rows = pc.mode.w;
        uint row0 = patch_points[20u * patch_id];
        vec3 origin = points[row0].xyz;
        vec3 lo0 = lo_rows > 0u ? points[lo_rows + row0].xyz : vec3(0.0);
        vec3 cv[20];
        for (int k = 0; k < 20; ++k) {
            uint row = patch_points[20u * patch_id + uint(k)];
            vec3 lo = lo_rows > 0u ? points[lo_rows + row].xyz : vec3(0.0);
            cv[k] = (points[row].xyz - origin) + (lo - lo0);
        }
        vec3 su, sv;
        vec3 net[16];
        gregory_eval_local(cv, origin, u, v, p, su, sv, net);
        nrm = gregory_normal(net, su, sv, u, v);
    } else {
        vec3 net[56];
        for (int k = 0; k < 56; ++k) net[k] = points[56u * patch_id + uint(k)].xyz;
        vec3 su, sv;
        beziex_eval(net, u, v, p, su, sv);
        nrm = beziex_normal(su, sv);
    }
#ifdef CAPTURE
    uint out_id = patch_id * n * n + uint(gl_VertexIndex);
    captured[out_id].position = vec4(p, 1.0);
    captured[out_id].normal = vec4(nrm, 0.0);
#endif
    world_pos = p;
    world_normal = nrm;
    patch_uv = vec2(u, v);
    gl_Position = pc.view_proj * vec4(p, 1.0);
}
