#version 460
// Shading modes: 0 Lambert + ambient + Phong (lecture model), 1 normals as colours, 2 zebra stripes of the
// reflected view direction (G1 shows as continuous stripes across patch edges), 3 the patch grid.
#include "surface_common.glsl"
#include "shading.glsl"
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
        c = 0.5 * n + 0.5;
    } else if (mode == 2u) {
        vec3 r = reflect(-v, n);
        float stripes = step(0.5, fract(6.0 * (r.z * 0.5 + 0.5)));
        c = mix(vec3(0.08), vec3(0.95), stripes);
    } else {
        float i = shade_phong(vec4(0.15, 0.75, 0.35, 40.0), n, l, v, pc.light.w, 1.0, true);
        c = pc.color.rgb * i;
        if (mode == 3u) {
            vec2 e = min(patch_uv, 1.0 - patch_uv);
            vec2 w = fwidth(patch_uv) * 1.5;
            float line = 1.0 - min(smoothstep(vec2(0.0), w, e).x, smoothstep(vec2(0.0), w, e).y);
            c = mix(c, vec3(0.05, 0.05, 0.1), line);
        }
    }
    out_color = vec4(c, 1.0);
}
