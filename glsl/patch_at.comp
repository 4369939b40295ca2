#version 460
// The Gregory surface at arbitrary (patch, u, v) points: one invocation per query (passes/patch_at.rs).
// The host located each query's patch and its local (u, v) (the ptex quadrant descent of
// gregvox::surface::LimitEvaluator) with the Jacobian J = d(u', v')/d(u, v) of that map; the kernel gathers
// the patch's 20 control points (f32 rows and their residuals), evaluates gregory_eval_local in patch-local
// coordinates (gregory.glsl: position and exact first partials) and maps the partials back to the ptex
// face's parameters by the chain rule: S_u = S_u'·J00 + S_v'·J10, S_v = S_u'·J01 + S_v'·J11. The exact second
// partials (gregory_second.glsl) follow as Jᵀ·H·J (the map is affine).
#include "gregory.glsl"
#include "gregory_second.glsl"
#include "dispatch.glsl"
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
struct Sample {
    vec4 position;
    vec4 du;
    vec4 dv;
    vec4 duu;
    vec4 duv;
    vec4 dvv;
};
layout(std430, set = 0, binding = 3) writeonly buffer Samples { Sample samples[]; };

void main() {
    uint q = linear_invocation();
    if (q >= pc.count) return;
    Query x = queries[q];
    vec3 local[20], hi0, lo0;
    patch_query_points(x, local, hi0, lo0);
    vec3 p, su, sv, net[16];
    gregory_eval_local(local, vec3(0.0), x.u, x.v, p, su, sv, net);
    // Position and first partials from gregory_eval_local (the evaluator every pass shares), the second
    // partials from their own pass over the net, whose first partials are discarded: twice the arithmetic
    // of one evaluation, on a pass whose cost is its 20 gathered points.
    vec3 fu, fv, huu, huv, hvv;
    gregory_partials_second(local, clamp(x.u, 0.0, 1.0), clamp(x.v, 0.0, 1.0), fu, fv, huu, huv, hvv);
    vec4 j = x.jac;   // J00, J01, J10, J11
    Sample s;
    s.position = vec4((p + lo0) + hi0, 1.0);
    s.du = vec4(su * j.x + sv * j.z, 0.0);
    s.dv = vec4(su * j.y + sv * j.w, 0.0);
    s.duu = vec4(huu * (j.x * j.x) + huv * (2.0 * j.x * j.z) + hvv * (j.z * j.z), 0.0);
    s.duv = vec4(huu * (j.x * j.y) + huv * (j.x * j.w + j.z * j.y) + hvv * (j.z * j.w), 0.0);
    s.dvv = vec4(huu * (j.y * j.y) + huv * (2.0 * j.y * j.w) + hvv * (j.w * j.w), 0.0);
    samples[q] = s;
}
