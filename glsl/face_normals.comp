#version 460
// Unnormalised face normals (twice the area times the unit normal for triangles; the fan sum of cross
// products for polygons): the transposed, action-mapped product M_φᵀ·P of the mesh matrix, one invocation per
// face gathering its corners in order — the same sums as gregvox::mesh::face_normals_unnormalized.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer FacePtr { uint face_ptr[]; };
layout(std430, set = 0, binding = 1) readonly buffer CornerVertex { uint corner_vertex[]; };
layout(std430, set = 0, binding = 2) readonly buffer Positions { vec4 positions[]; };
layout(std430, set = 0, binding = 3) writeonly buffer FaceNormals { vec4 face_normals[]; };
layout(push_constant) uniform Push { uint faces; } pc;
void main() {
    uint f = linear_invocation();
    if (f >= pc.faces) return;
    uint a = face_ptr[f], b = face_ptr[f + 1u];
    vec3 p0 = positions[corner_vertex[a]].xyz;
    precise vec3 n = vec3(0.0);
    for (uint c = a + 1u; c + 1u < b; ++c) {
        precise vec3 t = cross(positions[corner_vertex[c]].xyz - p0, positions[corner_vertex[c + 1u]].xyz - p0);
        n = n + t;
    }
    face_normals[f] = vec4(n, 0.0);
}
