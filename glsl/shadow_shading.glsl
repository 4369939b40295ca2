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

// A checker texture: 8 squares per unit of `uv` (a [0, 1]² UV layout shows 8 × 8), white and a dark
// grey, with a box-filtered edge (fwidth) so it does not alias at a distance.
vec3 mode_checker(vec2 uv) {
    vec2 f = uv * 8.0;
    vec2 w = max(fwidth(f), vec2(1e-4));
    // Box-filtered square wave: the integral of the ±1 wave over the pixel's footprint.
    vec2 i = (abs(fract((f - 0.5 * w) * 0.5) - 0.5) - abs(fract((f + 0.5 * w) * 0.5) - 0.5)) * 2.0 / w;
    float t = 0.5 - 0.5 * i.x * i.y;
    return mix(vec3(0.95, 0.93, 0.88), vec3(0.18, 0.2, 0.26), t);
}

// The lecture's model with the demo's material: ka 0.15, kd 0.75, ks 0.35, shininess 40.
float surface_phong(vec3 n, vec3 l, vec3 v, float ia, bool lit) {
    return shade_phong(vec4(0.15, 0.75, 0.35, 40.0), n, l, v, ia, 1.0, lit);
}
#endif
