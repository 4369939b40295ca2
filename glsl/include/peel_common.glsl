// Shared by the peel vertex and fragment shaders: the grid transform of one peel axis.
// Positions go to grid units per axis ((x - origin) / voxel size), so anisotropic voxels are unit cubes.
// Column (u, v) of the grid is pixel (u, v) of the width×height framebuffer; depth maps the depth range
// [lo, lo + span] (grid units; the grid's extent [0, depth], widened to hold the whole mesh) into
// [0.25, 0.75] so no fragment sits at the 0.0/1.0 clear values and no part of the mesh is clipped away.
layout(push_constant) uniform PeelPush {
    vec4 origin_depth_lo;      // xyz: grid origin, w: depth range start (grid units)
    vec4 inv_size_depth_span;  // xyz: 1 / voxel size, w: depth range length (grid units)
    uvec4 axes;                // x: u axis, y: v axis, z: depth axis
    uvec4 extent;              // x: width (voxels along u), y: height (along v), z: voxels along depth
} pc;
