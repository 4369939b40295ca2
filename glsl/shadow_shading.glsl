// Fragment-only colour modes shared by surface.frag (plain path, also the vertex-pull path) and
// shadowed_surface.frag (shadow map, curvature, ground). Included from glsl/ (not glsl/include/) because it
// uses fwidth, which a vertex shader including surface_common.glsl could not compile.
#ifndef GREGVOX_SHADOW_SHADING_GLSL
#define GREGVOX_SHADOW_SHADING_GLSL
#include "shading.glsl"

// Normals as colours.
vec3 mode_normals(vec3 n) { return 0.5 * n + 0.5; }

// Zebra stripes of the reflected view direction: G1 across a patch edge shows as continuous stripes.
vec3 mode_zebra(vec3 n, vec3 v) {
    vec3 r = reflect(-v, n);
    float stripes = step(0.5, fract(6.0 * (r.z * 0.5 + 0.5)));
    return mix(vec3(0.08), vec3(0.95), stripes);
}

// Darkens `c` along the patch boundaries (patch_uv = 0 or 1), lines about 1.5 pixels wide.
vec3 mode_wireframe(vec3 c, vec2 patch_uv) {
    vec2 e = min(patch_uv, 1.0 - patch_uv);
    vec2 w = fwidth(patch_uv) * 1.5;
    vec2 s = smoothstep(vec2(0.0), w, e);
    float line = 1.0 - min(s.x, s.y);
    return mix(c, vec3(0.05, 0.05, 0.1), line);
}

// The lecture's model with the demo's material: ka 0.15, kd 0.75, ks 0.35, shininess 40.
float surface_phong(vec3 n, vec3 l, vec3 v, float ia, bool lit) {
    return shade_phong(vec4(0.15, 0.75, 0.35, 40.0), n, l, v, ia, 1.0, lit);
}
#endif
