#version 460
// One level of the A-buffer's exclusive prefix sum over per-column fragment counts, in one buffer that holds
// every level back to back: level l at word `data`, its block totals (level l+1) at word `sums`.
// mode 0: exclusive scan of each 256-element block in place (Hillis–Steele in shared memory), block total to
//         sums[block]; mode 1: add sums[block] to every element of the block (the scanned level above).
// Integer adds in a fixed tree: the result is deterministic and exact. Dispatches beyond 65,535 groups
// arrive as 2D grids (dispatch.glsl); the workgroup's linear index is the block.
#include "dispatch.glsl"
layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) buffer Scan { uint v[]; };
layout(push_constant) uniform Push {
    uint data;  // first word of this level
    uint n;     // elements in this level
    uint sums;  // first word of the next level (block totals)
    uint mode;  // 0 scan blocks, 1 add block offsets
} pc;
shared uint s[256];

void main() {
    uint i = linear_invocation();
    uint block = i / 256u;
    uint lid = gl_LocalInvocationIndex;
    uint blocks = (pc.n + 255u) / 256u;
    if (pc.mode == 0u) {
        uint x = i < pc.n ? v[pc.data + i] : 0u;
        s[lid] = x;
        barrier();
        for (uint off = 1u; off < 256u; off <<= 1) {
            uint y = lid >= off ? s[lid - off] : 0u;
            barrier();
            s[lid] += y;
            barrier();
        }
        if (i < pc.n) v[pc.data + i] = s[lid] - x;
        if (lid == 255u && block < blocks) v[pc.sums + block] = s[255];
    } else if (i < pc.n) {
        v[pc.data + i] += v[pc.sums + block];
    }
}
