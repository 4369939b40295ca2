#version 460
// Stage 2 of the generalized winding number (src/voxel/gwn.rs): one invocation per voxel of the cells
// (2³ voxels) stage 1 listed (8 per cell, in list order). It sums the solid angles of every cap triangle at the
// voxel centre (w_C) and lists the voxel with w_C: as direct when the centre lies within `near` of a cap
// triangle, else as a crossing voxel when |w_C| ≥ ½ − margin. The list's capacity is the caller's; the count is always exact, so a
// caller sees an overflow. The loop over cap triangles is at most 16,384 long (the engine checks).
#include "dispatch.glsl"
#include "gwn.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Triangles { CapTriangle tris[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cells { uint cell_count; uint cells[]; };
layout(std430, set = 0, binding = 2) buffer Listed { uint listed_count; uint listed_pad[3]; GwnListed listed[]; };
layout(push_constant) uniform Push {
    dvec4 voxel_size;   // xyz: voxel size, w: near distance
    uvec4 dims;         // xyz: voxels per axis, w: cap triangles
    uvec4 bdims;        // xyz: cells per axis, w: list capacity
    uvec4 level;        // unused (the bricks pass's)
} pc;

void main() {
    uint g = linear_invocation();
    const uint per_cell = GWN_CELL * GWN_CELL * GWN_CELL;
    uint slot = g / per_cell;
    if (slot >= cell_count) return;
    uint b = cells[slot];
    uvec3 bc = uvec3(b % pc.bdims.x, (b / pc.bdims.x) % pc.bdims.y, b / (pc.bdims.x * pc.bdims.y));
    uint l = g % per_cell;
    uvec3 v = bc * GWN_CELL + uvec3(l % GWN_CELL, (l / GWN_CELL) % GWN_CELL, l / (GWN_CELL * GWN_CELL));
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
        uint at = atomicAdd(listed_count, 1u);
        if (at < pc.bdims.w) listed[at] = GwnListed(uvec4(v, near ? 1u : 0u), dvec2(w, 0.0lf));
    }
}
