#version 460
// Stage 3 of the generalized winding number (src/voxel/gwn.rs): the winding number of the mesh itself at
// the direct voxels. One invocation per (chunk of 4,096 triangles, voxel) writes that chunk's sum of solid
// angles to partial[chunk · voxels + voxel]; the caller adds the chunks in order (as the CPU does). Positions
// are the f32 vertices of the voxelized mesh made local to the grid in f64 (p − origin); the mesh's own
// triangles are the first `triangles` of the index buffer (the cap's follow them).
#include "dispatch.glsl"
#include "gwn.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Vertices { float pos[]; };
layout(std430, set = 0, binding = 1) readonly buffer Indices { uint idx[]; };
layout(std430, set = 0, binding = 2) readonly buffer Direct { uvec4 direct[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Partial { double partial[]; };
layout(push_constant) uniform Push {
    dvec4 origin;       // xyz: grid origin
    dvec4 voxel_size;   // xyz: voxel size
    uint voxels;        // direct voxels
    uint chunks;
    uint triangles;     // the mesh's triangles (without the cap)
    uint chunk_size;
} pc;

dvec3 vertex(uint v) {
    precise double x = double(pos[3u * v]) - pc.origin.x;
    precise double y = double(pos[3u * v + 1u]) - pc.origin.y;
    precise double z = double(pos[3u * v + 2u]) - pc.origin.z;
    return dvec3(x, y, z);
}

void main() {
    uint g = linear_invocation();
    if (g >= pc.voxels * pc.chunks) return;
    uint chunk = g / pc.voxels;
    uint v = g % pc.voxels;
    dvec3 p = gwn_centre(direct[v].xyz, pc.voxel_size.xyz);
    uint start = chunk * pc.chunk_size;
    uint end = min(start + pc.chunk_size, pc.triangles);
    precise double sum = 0.0lf;
    for (uint t = start; t < end; ++t) {
        precise double s = gwn_solid_angle(p, vertex(idx[3u * t]), vertex(idx[3u * t + 1u]), vertex(idx[3u * t + 2u]));
        sum = sum + s;
    }
    partial[g] = sum;
}
