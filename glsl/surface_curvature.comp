#version 460
// Mean and Gaussian curvature (H, K) of every Gregory patch on its (L+1)² grid, in the vertex order of
// gregory_eval.comp (vertex p·(L+1)² + j·(L+1) + i at (u, v) = (i/L, j/L)), so the surface shaders read it as a
// second vertex stream. Mirrors gregvox::geom::gregory::eval_generic with exact = second = true (first and
// second partials including the ∂Q, ∂²Q terms of the rational interior points) and
// gregvox::geom::curvature::gaussian_mean_curvature (fundamental forms; H signed w.r.t. S_u × S_v).
// Singular points (S_u ∥ S_v, EG − F² ≤ 0) get (0, 0): the CPU reference says `None` there.
// Self-contained on purpose (does not include gregory.glsl, whose evaluator is being rewritten separately).
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Curvature { vec2 curvature[]; };
layout(push_constant) uniform Push {
    uint patch_count;
    uint level;   // L
    uint patch_base;  // this dispatch's first patch; `curvature` is bound from its slot on (gregory_eval.rs)
    uint pad1;
} pc;

const float CORNER_EPS = 1e-6;

// Cubic Bernstein values, first and second derivatives at t.
void bern3(float t, out vec4 b, out vec4 d, out vec4 dd) {
    float s = 1.0 - t;
    b = vec4(s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t);
    d = vec4(-3.0 * s * s, 3.0 * s * s - 6.0 * t * s, 6.0 * t * s - 3.0 * t * t, 3.0 * t * t);
    dd = vec4(6.0 * s, 18.0 * t - 12.0, 6.0 - 18.0 * t, 6.0 * t);
}

// Q = P_b + f·(P_a − P_b), f = a/(a + b), a depends on u only (∂a/∂u = au), b on v only (∂b/∂v = bv).
// Outputs Q and its partials q[0..4] = Q_u, Q_v, Q_uu, Q_uv, Q_vv.
void rational(vec3 pa, vec3 pb, float a, float b, float au, float bv, out vec3 q, out vec3 dq[5]) {
    float d = a + b;
    if (d < CORNER_EPS) {
        q = pa;
        for (int k = 0; k < 5; ++k) dq[k] = vec3(0.0);
        return;
    }
    float inv = 1.0 / d;
    q = (pa * a + pb * b) * inv;
    vec3 diff = pa - pb;
    float inv2 = inv * inv;
    float fu = au * b * inv2;
    float fv = -(a * bv) * inv2;
    float fuu = -(2.0 * fu * au) * inv;
    float fvv = -(2.0 * fv * bv) * inv;
    float fuv = au * bv * inv2 - 2.0 * fu * bv * inv;
    dq[0] = diff * fu; dq[1] = diff * fv; dq[2] = diff * fuu; dq[3] = diff * fuv; dq[4] = diff * fvv;
}

shared vec3 s_cv[20];

// Bézier grid [row = v][col = u] in control point indices (geom::gregory::BEZIER_GRID, first index).
const int GRID[16] = int[16](0, 1, 7, 5,  2, 3, 9, 6,  16, 19, 13, 12,  15, 17, 11, 10);

vec2 curvature_at(float u, float v) {
    vec4 bu[3], bv[3];
    bern3(u, bu[0], bu[1], bu[2]);
    bern3(v, bv[0], bv[1], bv[2]);
    vec3 net[16];
    for (int k = 0; k < 16; ++k) net[k] = s_cv[GRID[k]];
    // Interior cells (col, row): (1,1) a = u, b = v; (2,1) 1−u, v; (1,2) u, 1−v; (2,2) 1−u, 1−v.
    vec3 dq[4][5];
    vec3 q;
    rational(s_cv[3], s_cv[4], u, v, 1.0, 1.0, q, dq[0]);             net[5] = q;
    rational(s_cv[9], s_cv[8], 1.0 - u, v, -1.0, 1.0, q, dq[1]);      net[6] = q;
    rational(s_cv[19], s_cv[18], u, 1.0 - v, 1.0, -1.0, q, dq[2]);    net[9] = q;
    rational(s_cv[13], s_cv[14], 1.0 - u, 1.0 - v, -1.0, -1.0, q, dq[3]); net[10] = q;
    // Contract the frozen net: (wu, wv) index pairs for S_u, S_v, S_uu, S_uv, S_vv.
    vec3 su = vec3(0.0), sv = vec3(0.0), suu = vec3(0.0), suv = vec3(0.0), svv = vec3(0.0);
    for (int j = 0; j < 4; ++j) {
        vec3 r0 = vec3(0.0), r1 = vec3(0.0), r2 = vec3(0.0);
        for (int i = 0; i < 4; ++i) {
            vec3 p = net[4 * j + i];
            r0 += p * bu[0][i];
            r1 += p * bu[1][i];
            r2 += p * bu[2][i];
        }
        su += r1 * bv[0][j];
        sv += r0 * bv[1][j];
        suu += r2 * bv[0][j];
        suv += r1 * bv[1][j];
        svv += r0 * bv[2][j];
    }
    // Exact terms of the interior cells.
    const ivec2 CELLS[4] = ivec2[4](ivec2(1, 1), ivec2(2, 1), ivec2(1, 2), ivec2(2, 2));
    for (int k = 0; k < 4; ++k) {
        int i = CELLS[k].x, j = CELLS[k].y;
        float w = bu[0][i] * bv[0][j];
        su += dq[k][0] * w;
        sv += dq[k][1] * w;
        suu += dq[k][0] * (2.0 * bu[1][i] * bv[0][j]) + dq[k][2] * w;
        suv += dq[k][1] * (bu[1][i] * bv[0][j]) + dq[k][0] * (bu[0][i] * bv[1][j]) + dq[k][3] * w;
        svv += dq[k][1] * (2.0 * bu[0][i] * bv[1][j]) + dq[k][4] * w;
    }
    vec3 nc = cross(su, sv);
    float ln = length(nc);
    if (!(ln > 0.0) || isinf(ln)) return vec2(0.0);
    vec3 n = nc / ln;
    float E = dot(su, su), F = dot(su, sv), G = dot(sv, sv);
    float L = dot(suu, n), M = dot(suv, n), N = dot(svv, n);
    float det = E * G - F * F;
    if (!(det > 0.0)) return vec2(0.0);
    float K = (L * N - M * M) / det;
    float H = (E * N - 2.0 * F * M + G * L) / (2.0 * det);
    return vec2(H, K);
}

void main() {
    uint L = pc.level;
    uint per_patch = (L + 1u) * (L + 1u);
    uint batch_patch = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (batch_patch >= pc.patch_count) return;   // uniform across the workgroup
    uint patch_id = pc.patch_base + batch_patch;
    uint t = gl_LocalInvocationIndex;
    if (t < 20u) s_cv[t] = points[patch_points[20u * patch_id + t]].xyz;
    barrier();
    for (uint local = t; local < per_patch; local += gl_WorkGroupSize.x) {
        uint j = local / (L + 1u);
        uint i = local - j * (L + 1u);
        curvature[batch_patch * per_patch + local] = curvature_at(float(i) / float(L), float(j) / float(L));
    }
}
