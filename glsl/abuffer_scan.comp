#version 460
#extension GL_EXT_control_flow_attributes : require
// One level of the A-buffer's exclusive prefix sum over per-column fragment counts, in one buffer that holds
// every level back to back: level l at word `data`, its block totals (level l+1) at word `sums`.
// A block is 1,024 elements: 64 invocations × 16 consecutive elements each. Each invocation scans its 16
// serially, the 64 partial sums are scanned in shared memory (Hillis–Steele, 6 steps), then written back.
// Few barriers per element matters on lavapipe, where a barrier switches every invocation's coroutine.
// mode 0: exclusive scan of each block in place, block total to sums[block];
// mode 1: add sums[block] (the scanned level above) to every element of the block.
// Integer adds in a fixed order: deterministic and exact. Dispatches beyond 65,535 groups arrive as 2D grids
// (dispatch.glsl); the workgroup's linear index is the block, trailing groups of a 2D grid do nothing.
#include "dispatch.glsl"
#define PER 16u
#define BLOCK 1024u
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) buffer Scan { uint v[]; };
layout(push_constant) uniform Push {
    uint data;  // first word of this level
    uint n;     // elements in this level
    uint sums;  // first word of the next level (block totals)
    uint mode;  // 0 scan blocks, 1 add block offsets
} pc;
shared uint s[64];

void main() {
    uint t = linear_invocation();
    uint block = t / 64u;
    uint lid = gl_LocalInvocationIndex;
    uint blocks = (pc.n + BLOCK - 1u) / BLOCK;
    uint first = t * PER;
    if (pc.mode == 0u) {
        // Two passes over the 16 elements (sum, then scan) rather than a private array: lavapipe's JIT
        // spends ~0.5 s on the array version.
        uint sum = 0u;
        [[dont_unroll]] for (uint k = 0u; k < PER; ++k) {
            uint idx = first + k;
            if (idx < pc.n) sum += v[pc.data + idx];
        }
        s[lid] = sum;
        barrier();
        [[dont_unroll]] for (uint off = 1u; off < 64u; off <<= 1) {
            uint y = lid >= off ? s[lid - off] : 0u;
            barrier();
            s[lid] += y;
            barrier();
        }
        uint run = s[lid] - sum;
        [[dont_unroll]] for (uint k = 0u; k < PER; ++k) {
            uint idx = first + k;
            if (idx < pc.n) {
                uint x = v[pc.data + idx];
                v[pc.data + idx] = run;
                run += x;
            }
        }
        if (lid == 63u && block < blocks) v[pc.sums + block] = s[63];
    } else if (first < pc.n) {
        uint add = v[pc.sums + block];
        [[dont_unroll]] for (uint k = 0u; k < PER; ++k) {
            uint idx = first + k;
            if (idx < pc.n) v[pc.data + idx] += add;
        }
    }
}
