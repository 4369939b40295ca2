#version 460
// The plain surface path (no descriptors; also the vertex-pull path's fragment shader): modes 0 Lambert +
// ambient + Phong (lecture model), 1 normals as colours, 2 zebra stripes, 3 wireframe of patch boundaries,
// 6 a checker over the patch parameters (the UVs are the shadowed path's);
// the curvature modes need the shadowed path's curvature buffer and fall back to Phong here.
#include "surface_common.glsl"
#include "shadow_shading.glsl"
layout(location = 0) in vec3 world_pos;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec2 patch_uv;
layout(location = 0) out vec4 out_color;
void main() {
    vec3 n = normalize(world_normal);
    vec3 v = normalize(pc.eye.xyz - world_pos);
    if (dot(n, v) < 0.0) n = -n;   // two-sided: open cages show their inside
    vec3 l = normalize(pc.light.xyz);
    uint mode = pc.mode.x;
    vec3 c;
    if (mode == 1u) {
        c = mode_normals(n);
    } else if (mode == 2u) {
        c = mode_zebra(n, v);
    } else if (mode == 6u) {
        c = mode_checker(patch_uv) * surface_phong(n, l, v, pc.light.w, true);
    } else {
        c = pc.color.rgb * surface_phong(n, l, v, pc.light.w, true);
        if (mode == 3u) c = mode_wireframe(c, patch_uv);
    }
    out_color = vec4(c, 1.0);
}
