#version 460
// The host's pipeline for gregvox's vertex buffer (examples/ash_host.rs): position (w = 1) and unit normal,
// 32 bytes a vertex, as `gregvox::api::SurfaceBuffers` documents.
layout(location = 0) in vec4 position;
layout(location = 1) in vec4 normal;
layout(push_constant) uniform Push {
    mat4 view_proj;
    vec4 eye;
} pc;
layout(location = 0) out vec3 world_pos;
layout(location = 1) out vec3 world_normal;
void main() {
    world_pos = position.xyz;
    world_normal = normal.xyz;
    gl_Position = pc.view_proj * vec4(position.xyz, 1.0);
}
