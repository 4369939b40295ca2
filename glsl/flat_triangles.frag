#version 460
layout(location = 0) in vec3 color;
layout(location = 0) out vec4 out_color;
layout(push_constant) uniform Push { vec4 solid; } pc;
void main() {
    // solid.a > 0 paints a flat colour (exact coverage tests); otherwise the interpolated palette.
    out_color = pc.solid.a > 0.0 ? vec4(pc.solid.rgb, 1.0) : vec4(color, 1.0);
}
