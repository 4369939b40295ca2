#version 460
// Copies the ray caster's image into the colour target: texel (frag - offset) / scale, no filtering, so the
// shown pixels are exactly the computed ones (each repeated scale x scale times).
layout(set = 0, binding = 0) uniform sampler2D image;
layout(push_constant) uniform Push { ivec2 offset; int scale; } pc;
layout(location = 0) out vec4 color;
void main() {
    color = texelFetch(image, (ivec2(gl_FragCoord.xy) - pc.offset) / pc.scale, 0);
}
