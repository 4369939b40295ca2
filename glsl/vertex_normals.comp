#version 460
// Area-weighted vertex normals: the plain action-mapped product M_φ·N_f, one invocation per vertex gathering
// the normals of the faces of its corners (vertex→corner CSR, rows in corner order) — no atomics, summed in the
// same order as gregvox::mesh::vertex_normals; vertices with no face (or a zero sum) get (0, 0, 0), never NaN.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer VcPtr { uint vc_ptr[]; };
layout(std430, set = 0, binding = 1) readonly buffer VcCorner { uint vc_corner[]; };
layout(std430, set = 0, binding = 2) readonly buffer CornerFace { uint corner_face[]; };
layout(std430, set = 0, binding = 3) readonly buffer FaceNormals { vec4 face_normals[]; };
layout(std430, set = 0, binding = 4) writeonly buffer VertexNormals { vec4 vertex_normals[]; };
layout(push_constant) uniform Push { uint vertices; } pc;
void main() {
    uint v = linear_invocation();
    if (v >= pc.vertices) return;
    precise vec3 acc = vec3(0.0);
    for (uint k = vc_ptr[v]; k < vc_ptr[v + 1u]; ++k) acc = acc + face_normals[corner_face[vc_corner[k]]].xyz;
    float l = length(acc);
    vertex_normals[v] = vec4(l > 0.0 ? acc / l : vec3(0.0), 0.0);
}
