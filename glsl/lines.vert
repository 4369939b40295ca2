#version 460
// Line vertices (position, colour; stride 32) from a host-written buffer, transformed by the camera.
layout(location = 0) in vec4 position;
layout(location = 1) in vec4 color;
layout(location = 0) out vec4 v_color;
layout(push_constant) uniform Push { mat4 view_proj; } pc;
void main() {
    v_color = color;
    gl_Position = pc.view_proj * vec4(position.xyz, 1.0);
}
