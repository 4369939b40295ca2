#version 460
// Triangles whose clip-space positions come from a storage buffer (xyzw per vertex), no vertex input:
// used by smoke tests and the minimal demo scene.
layout(std430, set = 0, binding = 0) readonly buffer Positions { vec4 pos[]; };
layout(location = 0) out vec3 color;
void main() {
    gl_Position = pos[gl_VertexIndex];
    const vec3 palette[3] = vec3[3](vec3(1, 0.2, 0.1), vec3(0.1, 1, 0.2), vec3(0.2, 0.3, 1));
    color = palette[gl_VertexIndex % 3];
}
