#version 460
// Orthographic projection of a mesh onto the width×height column plane of one peel axis (see
// peel_common.glsl). `invariant` keeps gl_Position bit-identical across the passes that re-rasterize the
// same triangles.
#include "peel_common.glsl"
layout(location = 0) in vec3 position;
invariant gl_Position;
void main() {
    vec3 g = (position - pc.origin_depth_lo.xyz) * pc.inv_size_depth_span.xyz;
    float u = g[pc.axes.x], v = g[pc.axes.y], d = g[pc.axes.z];
    float lo = pc.origin_depth_lo.w, span = pc.inv_size_depth_span.w;
    gl_Position = vec4(2.0 * u / float(pc.extent.x) - 1.0, 2.0 * v / float(pc.extent.y) - 1.0,
                       0.25 + 0.5 * (d - lo) / span, 1.0);
}
