#version 460
// One depth-peeling pass: keep only fragments strictly behind the previous layer (read from the previous
// pass's depth attachment) and store the layer as signed depth, +(z+1) front-facing, -(z+1) back-facing,
// 0 where the column has no more crossings. No early fragment tests: depth must not be written before the
// discard.
layout(set = 0, binding = 0) uniform sampler2D prev_depth;
layout(location = 0) out float layer;
void main() {
    float prev = texelFetch(prev_depth, ivec2(gl_FragCoord.xy), 0).r;
    if (gl_FragCoord.z <= prev) discard;
    layer = gl_FrontFacing ? gl_FragCoord.z + 1.0 : -(gl_FragCoord.z + 1.0);
}
