// Exact first and second partials of a Gregory patch in its own (u, v), the ∂Q and ∂²Q terms of the
// rational interior points included: gregvox::geom::gregory::eval_generic with exact = second = true.
// surface_curvature.comp reads them for (H, K), patch_at.comp for the second derivatives at located points.
// Translation-invariant: the control points may be given relative to any origin.
#ifndef GREGVOX_GREGORY_SECOND_GLSL
#define GREGVOX_GREGORY_SECOND_GLSL
#include "gregory.glsl"

// Cubic Bernstein values, first and second derivatives at t.
void gregory_bern3_second(float t, out vec4 b, out vec4 d, out vec4 dd) {
    float s = 1.0 - t;
    b = vec4(s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t);
    d = vec4(-3.0 * s * s, 3.0 * s * s - 6.0 * t * s, 6.0 * t * s - 3.0 * t * t, 3.0 * t * t);
    dd = vec4(6.0 * s, 18.0 * t - 12.0, 6.0 - 18.0 * t, 6.0 * t);
}

// Q = P_b + f·(P_a − P_b), f = a/(a + b), a depends on u only (∂a/∂u = au), b on v only (∂b/∂v = bv):
// gregory_rational's Q, Q_u, Q_v, and the second partials. Outputs q[0..4] = Q_u, Q_v, Q_uu, Q_uv, Q_vv.
void gregory_rational_second(vec3 pa, vec3 pb, float a, float b, float au, float bv, out vec3 q,
                             out vec3 dq[5]) {
    gregory_rational(pa, pb, a, b, au, bv, q, dq[0], dq[1]);
    float d = a + b;
    if (d < GREGORY_CORNER_EPS) {
        dq[2] = vec3(0.0); dq[3] = vec3(0.0); dq[4] = vec3(0.0);
        return;
    }
    float inv = 1.0 / d;
    vec3 diff = pa - pb;
    float inv2 = inv * inv;
    float fu = au * b * inv2;
    float fv = -(a * bv) * inv2;
    float fuu = -(2.0 * fu * au) * inv;
    float fvv = -(2.0 * fv * bv) * inv;
    float fuv = au * bv * inv2 - 2.0 * fu * bv * inv;
    dq[2] = diff * fuu; dq[3] = diff * fuv; dq[4] = diff * fvv;
}

// Bézier grid [row = v][col = u] in control point indices (geom::gregory::BEZIER_GRID, first index).
const int GREGORY_SECOND_GRID[16] = int[16](0, 1, 7, 5,  2, 3, 9, 6,  16, 19, 13, 12,  15, 17, 11, 10);

// S_u, S_v, S_uu, S_uv, S_vv of the patch `cv` (GREGORY_BASIS order) at (u, v).
void gregory_partials_second(in vec3 cv[20], float u, float v, out vec3 su, out vec3 sv, out vec3 suu,
                             out vec3 suv, out vec3 svv) {
    vec4 bu[3], bv[3];
    gregory_bern3_second(u, bu[0], bu[1], bu[2]);
    gregory_bern3_second(v, bv[0], bv[1], bv[2]);
    vec3 net[16];
    for (int k = 0; k < 16; ++k) net[k] = cv[GREGORY_SECOND_GRID[k]];
    // Interior cells (col, row): (1,1) a = u, b = v; (2,1) 1−u, v; (1,2) u, 1−v; (2,2) 1−u, 1−v.
    vec3 dq[4][5];
    vec3 q;
    gregory_rational_second(cv[3], cv[4], u, v, 1.0, 1.0, q, dq[0]);             net[5] = q;
    gregory_rational_second(cv[9], cv[8], 1.0 - u, v, -1.0, 1.0, q, dq[1]);      net[6] = q;
    gregory_rational_second(cv[19], cv[18], u, 1.0 - v, 1.0, -1.0, q, dq[2]);    net[9] = q;
    gregory_rational_second(cv[13], cv[14], 1.0 - u, 1.0 - v, -1.0, -1.0, q, dq[3]); net[10] = q;
    // Contract the frozen net: (wu, wv) index pairs for S_u, S_v, S_uu, S_uv, S_vv.
    su = vec3(0.0); sv = vec3(0.0); suu = vec3(0.0); suv = vec3(0.0); svv = vec3(0.0);
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
}
#endif
