#version 460
// The shadow map pass: depth only, from the light. Reads the same device-local surface vertex buffer as the
// colour pass (stride 32, position first); no fragment shader (depth comes from the rasterizer).
layout(push_constant) uniform ShadowPush { mat4 light_view_proj; } pc;
layout(location = 0) in vec4 position;
void main() {
    gl_Position = pc.light_view_proj * vec4(position.xyz, 1.0);
}
