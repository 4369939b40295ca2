#version 460
// The host's own geometry (examples/ash_host.rs): 2-D positions in clip space with a colour per vertex, a
// vertex layout gregvox knows nothing of.
layout(location = 0) in vec2 position;
layout(location = 1) in vec3 color;
layout(location = 0) out vec3 v_color;
void main() {
    v_color = color;
    gl_Position = vec4(position, 0.999, 1.0);
}
