#version 460
// Writes `count` triangles (3 clip-space vec4 each) on a ring turning with time `t`: the compute half of the
// minimal demo scene, whose output buffer the graphics pass reads as vertices with no copy.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Positions { vec4 pos[]; };
layout(push_constant) uniform Push { uint count; float t; float aspect; } pc;
void main() {
    uint k = linear_invocation();
    if (k >= pc.count) return;
    const float TAU = 6.283185307179586;
    float a = TAU * float(k) / float(pc.count) + pc.t;
    vec2 c = 0.6 * vec2(cos(a), sin(a));
    float r = 0.9 / sqrt(float(pc.count));
    for (uint v = 0; v < 3; ++v) {
        float b = a * 2.0 + TAU * float(v) / 3.0;
        vec2 p = c + r * vec2(cos(b), sin(b));
        pos[3 * k + v] = vec4(p.x / pc.aspect, p.y, 0.5, 1.0);
    }
}
