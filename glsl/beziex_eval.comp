#version 460
// Compute path for Beziex patches: one invocation per output vertex of the (L+1)² grid of each patch, the same
// vertex order and SurfaceVertex layout as gregory_eval.comp (so the same draw and the same comparisons).
#include "dispatch.glsl"
#include "beziex.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Nets { vec4 nets[]; };
#include "surface_vertex.glsl"
layout(std430, set = 0, binding = 1) writeonly buffer Vertices { Vertex vertices[]; };
layout(push_constant) uniform Push { uint patch_count; uint level; } pc;
void main() {
    uint L = pc.level;
    uint per_patch = (L + 1u) * (L + 1u);
    uint id = linear_invocation();
    if (id >= pc.patch_count * per_patch) return;
    uint patch_id = id / per_patch;
    uint local = id - patch_id * per_patch;
    uint j = local / (L + 1u);
    uint i = local - j * (L + 1u);
    vec3 net[56];
    for (int k = 0; k < 56; ++k) net[k] = nets[56u * patch_id + uint(k)].xyz;
    vec3 p, su, sv;
    beziex_eval(net, float(i) / float(L), float(j) / float(L), p, su, sv);
    vertices[id].position = vec4(p, 1.0);
    vertices[id].normal = vec4(beziex_normal(su, sv), 0.0);
}
