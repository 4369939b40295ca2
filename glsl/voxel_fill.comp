#version 460
// Turns the peeled layers of each column into bit-packed solid voxels. One invocation per column owns its
// ceil(depth/32) words (no atomics). Walking front to back, a crossing at depth z starts at voxel
// k = ceil(z_grid - 1/2); the segment before it is solid where the running winding is non-zero (rule 0),
// the crossing count is odd (rule 1, Harada & Koshizuka's pairing) or the winding is positive (rule 2).
// Nothing after the last crossing.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) uniform sampler2DArray layers;
layout(std430, set = 0, binding = 1) buffer Bits { uint bits[]; };
layout(push_constant) uniform Push {
    uint width;        // columns per row (voxels along u)
    uint layer_count;  // peeled layers
    uint words;        // ceil(depth/32)
    uint rule;         // 0 winding, 1 parity, 2 positive
    uint first_column; // first column (v*width + u) of this slab
    uint column_count; // columns in this slab
    uint depth;        // voxels along the peel axis
    float depth_lo;    // depth range start (grid units), as in peel_common.glsl
    float depth_span;  // depth range length (grid units)
} pc;

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
    ivec2 uv = ivec2(column % pc.width, column / pc.width);
    uint base = i * pc.words;
    for (uint w = 0u; w < pc.words; ++w) bits[base + w] = 0u;
    int winding = 0;
    uint crossings = 0u;
    uint k_prev = 0u;
    float r = float(pc.depth);
    for (uint l = 0u; l < pc.layer_count; ++l) {
        float s = texelFetch(layers, ivec3(uv, int(l)), 0).r;
        if (s == 0.0) break;
        float z_grid = (abs(s) - 1.0 - 0.25) * 2.0 * pc.depth_span + pc.depth_lo;
        uint k = uint(clamp(ceil(z_grid - 0.5), 0.0, r));
        bool inside = pc.rule == 0u ? winding != 0 : pc.rule == 1u ? (crossings & 1u) == 1u : winding > 0;
        if (inside && k > k_prev) set_range(base, k_prev, k);
        winding += s > 0.0 ? 1 : -1;
        crossings += 1u;
        k_prev = k;
    }
}
