// Shared by the peel vertex and fragment shaders: the grid transform of one peel axis.
// Column (u, v) of the grid is pixel (u, v) of the R×R framebuffer; depth maps the grid's extent along the
// peel axis into [0.25, 0.75] so no fragment sits at the 0.0/1.0 clear values.
layout(push_constant) uniform PeelPush {
    vec4 origin_inv_pitch;   // xyz: grid origin, w: 1 / pitch
    uvec4 axes_res;          // x: u axis, y: v axis, z: depth axis, w: resolution R
} pc;
