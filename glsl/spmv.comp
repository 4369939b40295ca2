#version 460
// y = A·x for a CSR matrix A (u32 row pointers and columns, f32 values) and vec4 points x, y (w = 1): one
// invocation per row, a gather summing in row order — no atomics, deterministic, and the same order as the
// CPU's SparseMatrix::spmv_f32, so results agree to f32 rounding. Used for Gregory control points (W·cage),
// subdivision (S·positions) and any stencil.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer RowPtr { uint row_ptr[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cols { uint cols[]; };
layout(std430, set = 0, binding = 2) readonly buffer Vals { float vals[]; };
layout(std430, set = 0, binding = 3) readonly buffer X { vec4 x[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Y { vec4 y[]; };
layout(push_constant) uniform Push { uint rows; } pc;
void main() {
    uint r = linear_invocation();
    if (r >= pc.rows) return;
    precise vec3 acc = vec3(0.0);
    for (uint k = row_ptr[r]; k < row_ptr[r + 1u]; ++k) {
        precise vec3 term = x[cols[k]].xyz * vals[k];
        acc = acc + term;
    }
    y[r] = vec4(acc, 1.0);
}
