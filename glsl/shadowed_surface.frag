#version 460
// The shadowed surface path: every shading mode of the demo.
//   0 Phong (lecture model) with hard shadows from the shadow map (one depth-compare tap, NEAREST: hard
//     edges, deterministic); 1 normals; 2 zebra; 3 wireframe of patch boundaries over shadowed Phong;
//   6 a checker texture over the cage's UVs (or the patch parameters), under shadowed Phong;
//   4 mean curvature H, 5 Gaussian curvature K: diverging colours white → red (positive) / blue (negative)
//     of tanh(H·s) and tanh(K·s²), s = the scene's size (float bits in mode.z), so a sphere of the scene's
//     size reads as a medium tint whatever the units.
// The ground plane (mode.w bit 0) is always shadowed Phong in its own colour.
#include "surface_common.glsl"
#include "shadow_shading.glsl"
layout(set = 0, binding = 0) uniform Light {
    mat4 light_view_proj;   // world → light clip space (orthographic, depth 0…1)
    vec4 params;            // x: constant depth bias in light depth units
} light;
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(location = 0) in vec3 world_pos;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec2 patch_uv;
layout(location = 3) in vec2 curvature;   // (H, K)
layout(location = 4) in vec2 surface_uv;  // the cage's UVs (mode.w bit 2), else the patch parameters
layout(location = 0) out vec4 out_color;

// 1 when lit, 0 in shadow; outside the light's frustum counts as lit.
float lit_fraction(vec3 p) {
    vec4 s = light.light_view_proj * vec4(p, 1.0);
    vec3 q = s.xyz / s.w;
    vec2 uv = q.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || q.z > 1.0) return 1.0;
    return texture(shadow_map, vec3(uv, q.z - light.params.x));
}

vec3 diverging(float x) {
    return x >= 0.0 ? mix(vec3(0.95), vec3(0.85, 0.12, 0.1), x) : mix(vec3(0.95), vec3(0.1, 0.3, 0.85), -x);
}

void main() {
    vec3 n = normalize(world_normal);
    vec3 v = normalize(pc.eye.xyz - world_pos);
    if (dot(n, v) < 0.0) n = -n;   // two-sided: open cages show their inside
    vec3 l = normalize(pc.light.xyz);
    uint mode = pc.mode.x;
    bool shadows = (pc.mode.w & 2u) != 0u;
    bool lit = !shadows || lit_fraction(world_pos) > 0.5;
    vec3 c;
    if ((pc.mode.w & 1u) != 0u) {
        c = pc.color.rgb * surface_phong(n, l, v, pc.light.w, lit);
    } else if (mode == 1u) {
        c = mode_normals(n);
    } else if (mode == 2u) {
        c = mode_zebra(n, v);
    } else if (mode == 4u || mode == 5u) {
        float s = uintBitsToFloat(pc.mode.z);
        float x = mode == 4u ? tanh(curvature.x * s) : tanh(curvature.y * s * s);
        // A little Lambert keeps the shape readable under the colour map.
        c = diverging(x) * (0.55 + 0.45 * shade_lambert(n, l));
    } else if (mode == 6u) {
        c = mode_checker(surface_uv) * surface_phong(n, l, v, pc.light.w, lit);
    } else {
        c = pc.color.rgb * surface_phong(n, l, v, pc.light.w, lit);
        if (mode == 3u) c = mode_wireframe(c, patch_uv);
    }
    out_color = vec4(c, 1.0);
}
