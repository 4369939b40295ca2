#version 460
// data[i] = i * scale + offset for i < count: the smoke test of compute dispatch, including dispatches
// split into 2D grids past maxComputeWorkGroupCount.x.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Data { uint data[]; };
layout(push_constant) uniform Push { uint count; uint scale; uint offset; } pc;
void main() {
    uint i = linear_invocation();
    if (i >= pc.count) return;
    data[i] = i * pc.scale + pc.offset;
}
