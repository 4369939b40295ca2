#version 460
// Orthographic projection of a mesh onto the R×R column plane of one peel axis (see peel_common.glsl).
// `invariant` keeps gl_Position bit-identical across the passes that re-rasterize the same triangles.
#include "peel_common.glsl"
layout(location = 0) in vec3 position;
invariant gl_Position;
void main() {
    vec3 g = (position - pc.origin_inv_pitch.xyz) * pc.origin_inv_pitch.w;
    float r = float(pc.axes_res.w);
    float u = g[pc.axes_res.x], v = g[pc.axes_res.y], d = g[pc.axes_res.z];
    gl_Position = vec4(2.0 * u / r - 1.0, 2.0 * v / r - 1.0, 0.25 + 0.5 * d / r, 1.0);
}
