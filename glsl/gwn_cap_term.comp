#version 460
// Stage 2 of the generalized winding number (src/voxel/gwn.rs): one invocation per voxel of the bricks
// stage 1 listed (512 per brick, in brick-list order). It sums the solid angles of every cap triangle at the
// voxel centre (w_C) and appends the voxel to the direct list when |w_C| ≥ ½ − margin or the centre lies
// within `near` of a cap triangle. The list's capacity is the caller's; the count is always exact, so a
// caller sees an overflow. The loop over cap triangles is at most 16,384 long (the engine checks).
#include "dispatch.glsl"
#include "gwn.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Triangles { CapTriangle tris[]; };
layout(std430, set = 0, binding = 1) readonly buffer Bricks { uint brick_count; uint bricks[]; };
layout(std430, set = 0, binding = 2) buffer Direct { uint direct_count; uint direct_pad[3]; uvec4 direct[]; };
layout(push_constant) uniform Push {
    dvec4 voxel_size;   // xyz: voxel size, w: near distance
    uvec4 dims;         // xyz: voxels per axis, w: cap triangles
    uvec4 bdims;        // xyz: bricks per axis, w: direct-list capacity
} pc;

void main() {
    uint g = linear_invocation();
    uint slot = g / 512u;
    if (slot >= brick_count) return;
    uint b = bricks[slot];
    uvec3 bc = uvec3(b % pc.bdims.x, (b / pc.bdims.x) % pc.bdims.y, b / (pc.bdims.x * pc.bdims.y));
    uint l = g % 512u;
    uvec3 v = bc * GWN_BRICK + uvec3(l % 8u, (l / 8u) % 8u, l / 64u);
    if (any(greaterThanEqual(v, pc.dims.xyz))) return;
    dvec3 p = gwn_centre(v, pc.voxel_size.xyz);
    double near_d = pc.voxel_size.w;
    precise double sum = 0.0lf;
    bool near = false;
    for (uint t = 0u; t < pc.dims.w; ++t) {
        CapTriangle tri = tris[t];
        precise double s = gwn_solid_angle(p, tri.a.xyz, tri.b.xyz, tri.c.xyz);
        sum = sum + s;
        if (!near) near = gwn_near_triangle(p, tri, near_d);
    }
    precise double w = sum / GWN_FOUR_PI;
    if (near || abs(w) >= 0.5lf - GWN_MARGIN) {
        uint at = atomicAdd(direct_count, 1u);
        if (at < pc.bdims.w) direct[at] = uvec4(v, 0u);
    }
}
