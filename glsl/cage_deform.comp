#version 460
// Animates a control cage on the GPU: deformed[i] = f(rest[i], t). Modes: 0 none, 1 twist about the box's
// vertical (z) axis, growing with height; 2 bend about the y axis; 3 travelling wave along x. Amplitude is
// relative to the box so any model deforms visibly but smoothly. Every mode is a smooth map of the rest
// positions, and the Gregory stencils are linear in the cage, so the surface stays G1 at every frame.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Rest { vec4 rest[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Deformed { vec4 deformed[]; };
layout(push_constant) uniform Push {
    vec4 box_min;     // xyz: rest bounding-box minimum
    vec4 box_size;    // xyz: its extent, w: the longest extent
    uint count;
    uint mode;
    float t;
    float amplitude;
} pc;
void main() {
    uint i = linear_invocation();
    if (i >= pc.count) return;
    vec3 p = rest[i].xyz;
    vec3 c = pc.box_min.xyz + 0.5 * pc.box_size.xyz;
    vec3 q = (p - pc.box_min.xyz) / max(pc.box_size.xyz, vec3(1e-20));   // [0,1]³
    float s = pc.box_size.w;
    if (pc.mode == 1u) {
        float a = pc.amplitude * sin(pc.t) * (q.z - 0.5) * 3.14159265;
        vec2 d = p.xy - c.xy;
        p.xy = c.xy + vec2(cos(a) * d.x - sin(a) * d.y, sin(a) * d.x + cos(a) * d.y);
    } else if (pc.mode == 2u) {
        float k = pc.amplitude * sin(pc.t) * 1.5 / s;     // curvature of the bend
        if (abs(k) > 1e-6) {
            float x = p.x - c.x;
            float r = 1.0 / k;
            float ang = x * k;
            float z = p.z - c.z;
            p.x = c.x + (r - z) * sin(ang);
            p.z = c.z + r - (r - z) * cos(ang);
        }
    } else if (pc.mode == 3u) {
        p.z += pc.amplitude * 0.08 * s * sin(6.2831853 * (q.x * 1.5 - 0.25 * pc.t));
        p.y += pc.amplitude * 0.04 * s * sin(6.2831853 * (q.z - 0.3 * pc.t));
    }
    deformed[i] = vec4(p, 1.0);
}
