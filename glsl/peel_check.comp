#version 460
// Finds the columns where depth peeling lost a fragment: strict LESS against the previous layer drops every
// fragment but one at an equal depth (coincident triangles: a cap on a cap, a duplicated face), so such a
// column peels fewer layers than the count pre-pass counted. One invocation per column compares the two and
// sets the column's bit in `lost`; the host recomputes those columns (voxel::cpu::refill_columns).
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) uniform sampler2DArray layers;
layout(std430, set = 0, binding = 1) readonly buffer Counts { uint counts[]; }; // [0]: max, then per column
layout(std430, set = 0, binding = 2) buffer Lost { uint lost[]; };              // one bit per column
layout(push_constant) uniform Push {
    uint width;        // columns per row (voxels along u)
    uint layer_count;  // peeled layers
    uint column_count; // columns (width × height)
    uint pad;
} pc;

void main() {
    uint column = linear_invocation();
    if (column >= pc.column_count) return;
    uint want = counts[1u + column];
    if (want == 0u) return;
    ivec2 uv = ivec2(column % pc.width, column / pc.width);
    uint peeled = 0u;
    while (peeled < pc.layer_count && texelFetch(layers, ivec3(uv, int(peeled)), 0).r != 0.0) ++peeled;
    if (peeled < want) atomicOr(lost[column >> 5], 1u << (column & 31u));
}
