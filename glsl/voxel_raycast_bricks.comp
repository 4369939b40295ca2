#version 460
// Brick occupancy for the two-level ray caster: one invocation per 4x4x4 brick ORs its voxels' bits
// (grid bit axis z; a brick's 4 bits of a column lie in one word since 4 divides 32; bits past R are zero by
// the grid contract). Output: one uint per brick, 1 if any voxel is solid, index (bk*NB + bj)*NB + bi.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Grid { uint bits[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Bricks { uint bricks[]; };
layout(push_constant) uniform Push { uint res; uint nb; } pc;
void main() {
    uint b = linear_invocation();
    uint nb = pc.nb;
    if (b >= nb * nb * nb) return;
    uint bi = b % nb, bj = (b / nb) % nb, bk = b / (nb * nb);
    uint words = (pc.res + 31u) / 32u;
    uint z0 = bk * 4u;
    uint occ = 0u;
    for (uint j = bj * 4u; j < min(bj * 4u + 4u, pc.res); ++j) {
        for (uint i = bi * 4u; i < min(bi * 4u + 4u, pc.res); ++i) {
            occ |= (bits[(j * pc.res + i) * words + z0 / 32u] >> (z0 & 31u)) & 0xfu;
        }
    }
    bricks[b] = occ != 0u ? 1u : 0u;
}
