#version 460
// The shadowed surface path: the Gregory vertex buffer (binding 0: position, normal; stride 32) plus the
// per-vertex curvature buffer (binding 1: vec2 (H, K); stride 8) written by surface_curvature.comp in the same
// vertex order, and the UV stream (binding 2: a UV surface's vertices, u and v first; stride 32). patch_uv is recovered from the vertex index: vertex p·(L+1)² + j·(L+1) + i is (i/L, j/L).
// The ground plane (flag bit 0) has no patch grid; its patch_uv is unused.
#include "surface_common.glsl"
layout(location = 0) in vec4 position;
layout(location = 1) in vec4 normal;
layout(location = 2) in vec2 curvature;
layout(location = 4) in vec4 uv_vertex;   // binding 2: a UV surface's vertex (u, v, 0, 1), or the position
layout(location = 0) out vec3 world_pos;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 patch_uv;
layout(location = 3) out vec2 out_curvature;
layout(location = 4) out vec2 surface_uv;
void main() {
    world_pos = position.xyz;
    world_normal = normal.xyz;
    uint n = pc.mode.y + 1u;
    uint local = uint(gl_VertexIndex) % (n * n);
    patch_uv = vec2(float(local % n), float(local / n)) / float(max(pc.mode.y, 1u));
    out_curvature = curvature;
    surface_uv = (pc.mode.w & 4u) != 0u ? uv_vertex.xy : patch_uv;
    gl_Position = pc.view_proj * vec4(position.xyz, 1.0);
}
