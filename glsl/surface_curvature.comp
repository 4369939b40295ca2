#version 460
// Mean and Gaussian curvature (H, K) of every Gregory patch on its (L+1)² grid, in the vertex order of
// gregory_eval.comp (vertex p·(L+1)² + j·(L+1) + i at (u, v) = (i/L, j/L)), so the surface shaders read it as a
// second vertex stream. Mirrors gregvox::geom::gregory::eval_generic with exact = second = true (first and
// second partials including the ∂Q, ∂²Q terms of the rational interior points) and
// gregvox::geom::curvature::gaussian_mean_curvature (fundamental forms; H signed w.r.t. S_u × S_v).
// Singular points (S_u ∥ S_v, EG − F² ≤ 0) get (0, 0): the CPU reference says `None` there.
#include "gregory_second.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Curvature { vec2 curvature[]; };
layout(push_constant) uniform Push {
    uint patch_count;
    uint level;   // L
    uint patch_base;  // this dispatch's first patch; `curvature` is bound from its slot on (gregory_eval.rs)
    uint pad1;
} pc;

shared vec3 s_cv[20];

vec2 curvature_at(float u, float v) {
    vec3 cv[20];
    for (int k = 0; k < 20; ++k) cv[k] = s_cv[k];
    vec3 su, sv, suu, suv, svv;
    gregory_partials_second(cv, u, v, su, sv, suu, suv, svv);
    vec3 nc = cross(su, sv);
    float ln = length(nc);
    if (!(ln > 0.0) || isinf(ln)) return vec2(0.0);
    vec3 n = nc / ln;
    float E = dot(su, su), F = dot(su, sv), G = dot(sv, sv);
    float L = dot(suu, n), M = dot(suv, n), N = dot(svv, n);
    float det = E * G - F * F;
    if (!(det > 0.0)) return vec2(0.0);
    float K = (L * N - M * M) / det;
    float H = (E * N - 2.0 * F * M + G * L) / (2.0 * det);
    return vec2(H, K);
}

void main() {
    uint L = pc.level;
    uint per_patch = (L + 1u) * (L + 1u);
    uint batch_patch = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (batch_patch >= pc.patch_count) return;   // uniform across the workgroup
    uint patch_id = pc.patch_base + batch_patch;
    uint t = gl_LocalInvocationIndex;
    if (t < 20u) s_cv[t] = points[patch_points[20u * patch_id + t]].xyz;
    barrier();
    for (uint local = t; local < per_patch; local += gl_WorkGroupSize.x) {
        uint j = local / (L + 1u);
        uint i = local - j * (L + 1u);
        curvature[batch_patch * per_patch + local] = curvature_at(float(i) / float(L), float(j) / float(L));
    }
}
