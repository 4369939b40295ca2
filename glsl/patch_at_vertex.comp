#version 460
// A surface's vertices at located (patch, u, v) points (passes/patch_at.rs, `PatchAtPass::new_vertices`):
// the device surface's ptex layout (engine/gregory.rs), one grid per ptex face whatever the depths of the
// patches under it. Each invocation evaluates one query as glsl/patch_at.comp does and writes a surface
// vertex: the position and the unit normal of the patch-local partials (gregory_normal: the same fallback
// as the patch grids where they are degenerate). Grid points two faces share carry the same query, so
// their vertices have the same bits and the drawn mesh has no crack.
#include "gregory.glsl"
#include "dispatch.glsl"
#include "surface_vertex.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(push_constant) uniform Push {
    uint count;          // queries in this dispatch
    uint residual_rows;  // rows of f32 points before their residuals (0: none)
    uint pad0;
    uint pad1;
} pc;
#include "patch_query.glsl"
layout(std430, set = 0, binding = 2) readonly buffer Queries { Query queries[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Vertices { Vertex vertices[]; };

void main() {
    uint q = linear_invocation();
    if (q >= pc.count) return;
    Query x = queries[q];
    vec3 p, su, sv, net[16];
    patch_query_eval(x, p, su, sv, net);
    vertices[q].position = vec4(p, 1.0);
    vertices[q].normal = vec4(gregory_normal(net, su, sv, x.u, x.v), 0.0);
}
