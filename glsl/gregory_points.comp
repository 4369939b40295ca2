#version 460
// Gregory control points P = W·cage for an affine stencil matrix W (every row sums to 1), written as an
// unevaluated sum hi + lo so the evaluation can work in patch-local coordinates without the f32 rounding of
// world-space points.
//
// Why: W·cage summed in world coordinates (spmv.comp) and stored as f32 carries an error ≈ 2⁻²⁴·|P| per
// point, independent from point to point. The derivatives of a patch are differences of its points, so that
// error, proportional to the distance from the world origin rather than to the patch size, tilts the normals;
// at folds of a deformed cage (S_u nearly parallel to S_v) it reached 9e-3 rad across shared edges. Here
//   P_r = ref + Σ_k w_k·(x_k − ref),  ref = x[first column of row r]
// whose rounding scales with the patch size (the weights' own f32 rounding, too, multiplies only x_k − ref:
// an affine row stays affine), and hi = f32(ref + rel), lo = the exact residual (TwoSum): hi + lo = ref + rel.
//
// Layout: y[r] = (hi, 1) for r < rows, y[rows + r] = (lo, 0). Readers that want one f32 point use y[r] alone.
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
    uint begin = row_ptr[r], end = row_ptr[r + 1u];
    if (begin == end) {   // an empty row: the zero point
        y[r] = vec4(0.0, 0.0, 0.0, 1.0);
        y[pc.rows + r] = vec4(0.0);
        return;
    }
    precise vec3 ref = x[cols[begin]].xyz;
    precise vec3 rel = vec3(0.0);
    for (uint k = begin; k < end; ++k) {
        precise vec3 term = (x[cols[k]].xyz - ref) * vals[k];
        rel = rel + term;
    }
    // TwoSum (Knuth): s = fl(a + b), err = (a − (s − b')) + (b − b'), b' = s − a; exact without FMA contraction.
    precise vec3 s = ref + rel;
    precise vec3 bv = s - ref;
    precise vec3 av = s - bv;
    precise vec3 err = (ref - av) + (rel - bv);
    y[r] = vec4(s, 1.0);
    y[pc.rows + r] = vec4(err, 0.0);
}
