#version 460
// Stage 1 of the generalized winding number (src/voxel/gwn.rs::box_needs_cap_term): one invocation per box
// of voxels, appended (linear index in its level's grid) to `outs` unless its bound clears it. Level 0: the
// coarsest boxes (32³ voxels) of the grid; the next levels: the boxes (16³ … 2³) among the GWN_SPLIT³
// children of the `in_count` boxes of the level above listed in `ins`. A box is cleared when
// every cap triangle lies farther than r + near from its centre c and |w_C(c)| + r · Σ edge / (d − r)²,
// over 4π, stays under ½ − margin. The loop over cap triangles is at most 16,384 long (the engine checks;
// lavapipe cuts loops past 65,535).
#include "dispatch.glsl"
#include "gwn.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Triangles { CapTriangle tris[]; };
layout(std430, set = 0, binding = 1) readonly buffer Ins { uint in_count; uint ins[]; };
layout(std430, set = 0, binding = 2) buffer Outs { uint out_count; uint outs[]; };
layout(push_constant) uniform Push {
    dvec4 voxel_size;   // xyz: voxel size, w: near distance
    uvec4 dims;         // xyz: voxels per axis, w: cap triangles
    uvec4 bdims;        // xyz: boxes per axis at this level, w: invocations
    uvec4 level;        // x: the level (0: coarsest), y: its box edge in voxels, zw: unused
} pc;

void main() {
    uint g = linear_invocation();
    if (g >= pc.bdims.w) return;
    uint edge = pc.level.y;
    uvec3 box;
    if (pc.level.x == 0u) {
        box = uvec3(g % pc.bdims.x, (g / pc.bdims.x) % pc.bdims.y, g / (pc.bdims.x * pc.bdims.y));
    } else {
        const uint kids = GWN_SPLIT * GWN_SPLIT * GWN_SPLIT;
        uint slot = g / kids;
        if (slot >= in_count) return;
        uint pedge = edge * GWN_SPLIT;
        uvec3 pdims = (pc.dims.xyz + pedge - 1u) / pedge;
        uint c = ins[slot];
        uvec3 parent = uvec3(c % pdims.x, (c / pdims.x) % pdims.y, c / (pdims.x * pdims.y));
        uint s = g % kids;
        box = parent * GWN_SPLIT + uvec3(s % GWN_SPLIT, (s / GWN_SPLIT) % GWN_SPLIT, s / (GWN_SPLIT * GWN_SPLIT));
        if (any(greaterThanEqual(box, pc.bdims.xyz))) return;
    }
    uint index = box.x + pc.bdims.x * (box.y + pc.bdims.y * box.z);
    dvec3 size = pc.voxel_size.xyz;
    double near = pc.voxel_size.w;
    dvec3 lo = gwn_centre(box * edge, size);
    dvec3 hi = gwn_centre(min(box * edge + edge, pc.dims.xyz) - 1u, size);
    precise double cx = (lo.x + hi.x) * 0.5lf;
    precise double cy = (lo.y + hi.y) * 0.5lf;
    precise double cz = (lo.z + hi.z) * 0.5lf;
    dvec3 c = dvec3(cx, cy, cz);
    precise double r = 0.5lf * gwn_norm(gwn_sub(hi, lo));
    bool needed = false;
    for (uint t = 0u; t < pc.dims.w; ++t) {
        if (gwn_gap(c, r, tris[t], near) <= near) {
            needed = true;
            break;
        }
    }
    if (!needed) {
        precise double sum = 0.0lf;
        precise double gradient = 0.0lf;
        for (uint t = 0u; t < pc.dims.w; ++t) {
            CapTriangle tri = tris[t];
            precise double g = gwn_gap(c, r, tri, near);
            precise double s = gwn_solid_angle(c, tri.a.xyz, tri.b.xyz, tri.c.xyz);
            sum = sum + s;
            precise double term = tri.a.w / (g * g);
            gradient = gradient + term;
        }
        precise double bound = (abs(sum) + r * gradient) / GWN_FOUR_PI;
        needed = bound >= 0.5lf - GWN_MARGIN;
    }
    if (needed) {
        uint slot = atomicAdd(out_count, 1u);
        outs[slot] = index;
    }
}
