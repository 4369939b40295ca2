#version 460
// Draws the Gregory surface straight from the evaluation pass's vertex buffer (position, normal; stride 32).
#include "surface_common.glsl"
layout(location = 0) in vec4 position;
layout(location = 1) in vec4 normal;
layout(location = 0) out vec3 world_pos;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 patch_uv;
void main() {
    world_pos = position.xyz;
    world_normal = normal.xyz;
    uint n = pc.mode.y + 1u;
    uint local = uint(gl_VertexIndex) % (n * n);
    patch_uv = vec2(float(local % n), float(local / n)) / float(max(pc.mode.y, 1u));
    gl_Position = pc.view_proj * vec4(position.xyz, 1.0);
}
