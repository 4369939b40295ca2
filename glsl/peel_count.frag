#version 460
// Count pre-pass: fragments per column (= crossings, duplicates included) and their maximum, which bounds the
// number of peeling passes before any is run.
#include "peel_common.glsl"
layout(std430, set = 0, binding = 1) buffer Counts { uint max_count; uint counts[]; };
void main() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    uint c = atomicAdd(counts[p.y * pc.extent.x + p.x], 1u) + 1u;
    atomicMax(max_count, c);
}
