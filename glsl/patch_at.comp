#version 460
// The Gregory surface at arbitrary (patch, u, v) points: one invocation per query (passes/patch_at.rs).
// The host located each query's patch and its local (u, v) (the ptex quadrant descent of
// gregvox::surface::LimitEvaluator) with the Jacobian J = d(u', v')/d(u, v) of that map; the kernel gathers
// the patch's 20 control points (f32 rows and their residuals), evaluates gregory_eval_local in patch-local
// coordinates (gregory.glsl: position and exact first partials) and maps the partials back to the ptex
// face's parameters by the chain rule: S_u = S_u'·J00 + S_v'·J10, S_v = S_u'·J01 + S_v'·J11.
#include "gregory.glsl"
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
};
layout(std430, set = 0, binding = 3) writeonly buffer Samples { Sample samples[]; };

void main() {
    uint q = linear_invocation();
    if (q >= pc.count) return;
    Query x = queries[q];
    vec3 p, su, sv, net[16];
    patch_query_eval(x, p, su, sv, net);
    Sample s;
    s.position = vec4(p, 1.0);
    s.du = vec4(su * x.jac.x + sv * x.jac.z, 0.0);
    s.dv = vec4(su * x.jac.y + sv * x.jac.w, 0.0);
    samples[q] = s;
}
