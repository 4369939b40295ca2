#version 460
// Axis-aligned bounds of a vertex buffer (positions first, `stride_floats` floats per vertex): a workgroup
// reduction in shared memory, then six atomics on order-preserving uint encodings of the floats
// (bounds[0..3] = min xyz, bounds[3..6] = max xyz; the caller initialises them to the identity).
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Vertices { float v[]; };
layout(std430, set = 0, binding = 1) buffer Bounds { uint bounds[6]; };
layout(push_constant) uniform Push { uint count; uint stride_floats; } pc;
shared vec3 s_min[64];
shared vec3 s_max[64];
uint encode(float f) {
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}
void main() {
    uint i = linear_invocation();
    uint t = gl_LocalInvocationIndex;
    vec3 lo = vec3(3.4e38), hi = vec3(-3.4e38);
    if (i < pc.count) {
        uint b = i * pc.stride_floats;
        vec3 p = vec3(v[b], v[b + 1u], v[b + 2u]);
        lo = p;
        hi = p;
    }
    s_min[t] = lo;
    s_max[t] = hi;
    barrier();
    for (uint s = 32u; s > 0u; s >>= 1) {
        if (t < s) {
            s_min[t] = min(s_min[t], s_min[t + s]);
            s_max[t] = max(s_max[t], s_max[t + s]);
        }
        barrier();
    }
    if (t == 0u) {
        for (int a = 0; a < 3; ++a) {
            atomicMin(bounds[a], encode(s_min[0][a]));
            atomicMax(bounds[3 + a], encode(s_max[0][a]));
        }
    }
}
