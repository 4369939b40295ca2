#version 460
// A-buffer fill: one invocation per column sorts the column's fragments front to back (insertion sort in
// place: columns hold few crossings) by (|s|, s) — a total order, so equal depths sort deterministically —
// then fills exactly as voxel_fill.comp: a crossing at z starts at voxel k = ceil(z_grid - 1/2); the segment
// before it is solid where the running winding is non-zero (rule 0), the crossing count is odd (rule 1) or
// the winding is positive (rule 2);
// nothing after the last crossing. Each invocation owns its ceil(depth/32) output words (zeros included).
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Offsets { uint offsets[]; };
layout(std430, set = 0, binding = 1) buffer Frags { float frags[]; };
layout(std430, set = 0, binding = 2) buffer Bits { uint bits[]; };
layout(push_constant) uniform Push {
    uint width;        // columns per row (voxels along u)
    uint words;        // ceil(depth/32)
    uint rule;         // 0 winding, 1 parity, 2 positive
    uint first_column; // first column (v*width + u) of this slab
    uint column_count; // columns in this slab
    uint depth;        // voxels along the peel axis
    float depth_lo;    // depth range start (grid units), as in peel_common.glsl
    float depth_span;  // depth range length (grid units)
} pc;

bool before(float a, float b) {
    return abs(a) < abs(b) || (abs(a) == abs(b) && a < b);
}

void set_range(uint base, uint k0, uint k1) {
    uint k = k0;
    while (k < k1) {
        uint b = k & 31u;
        uint n = min(32u - b, k1 - k);
        uint mask = n == 32u ? 0xffffffffu : (((1u << n) - 1u) << b);
        bits[base + (k >> 5)] |= mask;
        k += n;
    }
}

void main() {
    uint i = linear_invocation();
    if (i >= pc.column_count) return;
    uint column = pc.first_column + i;
    uint b = offsets[column];
    uint e = offsets[column + 1u];
    for (uint a = b + 1u; a < e; ++a) {
        float x = frags[a];
        uint c = a;
        while (c > b && before(x, frags[c - 1u])) {
            frags[c] = frags[c - 1u];
            --c;
        }
        frags[c] = x;
    }
    uint base = i * pc.words;
    for (uint w = 0u; w < pc.words; ++w) bits[base + w] = 0u;
    int winding = 0;
    uint crossings = 0u;
    uint k_prev = 0u;
    float r = float(pc.depth);
    for (uint a = b; a < e; ++a) {
        float s = frags[a];
        float z_grid = (abs(s) - 1.0 - 0.25) * 2.0 * pc.depth_span + pc.depth_lo;
        uint k = uint(clamp(ceil(z_grid - 0.5), 0.0, r));
        bool inside = pc.rule == 0u ? winding != 0 : pc.rule == 1u ? (crossings & 1u) == 1u : winding > 0;
        if (inside && k > k_prev) set_range(base, k_prev, k);
        winding += s > 0.0 ? 1 : -1;
        crossings += 1u;
        k_prev = k;
    }
}
