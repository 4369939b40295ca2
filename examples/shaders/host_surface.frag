#version 460
// Normals as colours, two-sided: what gregvox's own surface pass draws in its "normals" mode, so the two
// renderers' frames can be compared.
layout(location = 0) in vec3 world_pos;
layout(location = 1) in vec3 world_normal;
layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 eye;
} pc;
layout(location = 0) out vec4 out_color;
void main() {
    vec3 n = normalize(world_normal);
    vec3 v = normalize(pc.eye.xyz - world_pos);
    if (dot(n, v) < 0.0) n = -n;
    out_color = vec4(0.5 * n + 0.5, 1.0);
}
