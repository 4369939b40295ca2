// The bicubic Gregory patch (20 control points, OpenSubdiv GREGORY_BASIS order), evaluated with exact
// partial derivatives, the corner 0/0 guard and the degenerate-normal fallback. It mirrors
// gregvox::geom::gregory::eval_generic operation for operation (see that function's steps), so the f32 CPU
// mirror is the reference for the GPU. Shared by gregory_eval.comp and the vertex-pull path.
#ifndef GREGVOX_GREGORY_GLSL
#define GREGVOX_GREGORY_GLSL

const float GREGORY_CORNER_EPS = 1e-6;

// Bézier grid [row = v][col = u] → control point (a); interior cells pair (a, b).
const int GREGORY_GRID[16] = int[16](0, 1, 7, 5,  2, 3, 9, 6,  16, 19, 13, 12,  15, 17, 11, 10);
const int GREGORY_PAIR[16] = int[16](0, 1, 7, 5,  2, 4, 8, 6,  16, 18, 14, 12,  15, 17, 11, 10);

// Cubic Bernstein values (b) and derivatives (d) at t.
void gregory_bern3(float t, out vec4 b, out vec4 d) {
    float s = 1.0 - t;
    b = vec4(s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t);
    d = vec4(-3.0 * s * s, 3.0 * s * s - 6.0 * t * s, 6.0 * t * s - 3.0 * t * t, 3.0 * t * t);
}

// Q = (pa·a + pb·b)/(a + b) and its partials; a depends on u only (∂a/∂u = au), b on v only (∂b/∂v = bv).
void gregory_rational(vec3 pa, vec3 pb, float a, float b, float au, float bv,
                      out vec3 q, out vec3 qu, out vec3 qv) {
    float d = a + b;
    if (d < GREGORY_CORNER_EPS) {
        q = pa; qu = vec3(0.0); qv = vec3(0.0);
        return;
    }
    float inv = 1.0 / d;
    q = (pa * a + pb * b) * inv;
    vec3 diff = pa - pb;
    float inv2 = inv * inv;
    float fu = au * b * inv2;
    float fv = -(a * bv) * inv2;
    qu = diff * fu;
    qv = diff * fv;
}

// Position and exact first partials at (u, v) ∈ [0,1]²; also returns the frozen net for the normal fallback.
void gregory_eval(in vec3 cv[20], float u, float v, out vec3 p, out vec3 su, out vec3 sv, out vec3 net[16]) {
    u = clamp(u, 0.0, 1.0);
    v = clamp(v, 0.0, 1.0);
    vec4 bu, du, bv, dv;
    gregory_bern3(u, bu, du);
    gregory_bern3(v, bv, dv);
    float uu = 1.0 - u, vv = 1.0 - v;
    for (int k = 0; k < 16; ++k) net[k] = cv[GREGORY_GRID[k]];
    vec3 dqu[4], dqv[4];
    // Interior cells in the order Q11 (1,1), Q21 (2,1), Q12 (1,2), Q22 (2,2).
    gregory_rational(cv[3], cv[4], u, v, 1.0, 1.0, net[5], dqu[0], dqv[0]);
    gregory_rational(cv[9], cv[8], uu, v, -1.0, 1.0, net[6], dqu[1], dqv[1]);
    gregory_rational(cv[19], cv[18], u, vv, 1.0, -1.0, net[9], dqu[2], dqv[2]);
    gregory_rational(cv[13], cv[14], uu, vv, -1.0, -1.0, net[10], dqu[3], dqv[3]);
    p = vec3(0.0); su = vec3(0.0); sv = vec3(0.0);
    for (int j = 0; j < 4; ++j) {
        vec3 rp = vec3(0.0), ru = vec3(0.0);
        for (int i = 0; i < 4; ++i) {
            rp = rp + net[4 * j + i] * bu[i];
            ru = ru + net[4 * j + i] * du[i];
        }
        p = p + rp * bv[j];
        su = su + ru * bv[j];
        sv = sv + rp * dv[j];
    }
    // Exact-derivative correction: Σ B_i(u) B_j(v) ∂Q_ij over the interior cells.
    su = su + dqu[0] * (bu[1] * bv[1]); sv = sv + dqv[0] * (bu[1] * bv[1]);
    su = su + dqu[1] * (bu[2] * bv[1]); sv = sv + dqv[1] * (bu[2] * bv[1]);
    su = su + dqu[2] * (bu[1] * bv[2]); sv = sv + dqv[2] * (bu[1] * bv[2]);
    su = su + dqu[3] * (bu[2] * bv[2]); sv = sv + dqv[3] * (bu[2] * bv[2]);
}

// Unit normal with the fallback of geom::gregory (notes §1.5): S_u × S_v unless degenerate, then the
// diagonals of the de Casteljau bilinear hull, then the corner diagonals, then +Z. Never NaN.
vec3 gregory_normal(in vec3 net[16], vec3 su, vec3 sv, float u, float v) {
    vec3 n = cross(su, sv);
    float ln = length(n);
    float scale = length(su) + length(sv);
    if (ln > 1e-5 * scale * scale && !isinf(ln) && !isnan(ln)) return n / ln;
    u = clamp(u, 0.0, 1.0);
    v = clamp(v, 0.0, 1.0);
    vec3 rows[8];
    for (int j = 0; j < 4; ++j) {
        vec3 a0 = mix(net[4 * j], net[4 * j + 1], u);
        vec3 a1 = mix(net[4 * j + 1], net[4 * j + 2], u);
        vec3 a2 = mix(net[4 * j + 2], net[4 * j + 3], u);
        rows[2 * j] = mix(a0, a1, u);
        rows[2 * j + 1] = mix(a1, a2, u);
    }
    vec3 c[4];
    for (int col = 0; col < 2; ++col) {
        vec3 a0 = mix(rows[col], rows[2 + col], v);
        vec3 a1 = mix(rows[2 + col], rows[4 + col], v);
        vec3 a2 = mix(rows[4 + col], rows[6 + col], v);
        c[2 * col] = mix(a0, a1, v);
        c[2 * col + 1] = mix(a1, a2, v);
    }
    // c = [c00, c01, c10, c11]
    vec3 hull = cross(c[3] - c[0], c[1] - c[2]);
    float lh = length(hull);
    if (lh > 0.0 && !isinf(lh)) return hull / lh;
    vec3 corners = cross(net[15] - net[0], net[12] - net[3]);
    float lc = length(corners);
    if (lc > 0.0 && !isinf(lc)) return corners / lc;
    return vec3(0.0, 0.0, 1.0);
}

// A boundary cubic at t: the canonical edge evaluation shared bit for bit by both patches of an edge.
vec3 gregory_edge(vec3 p0, vec3 p1, vec3 p2, vec3 p3, float t) {
    vec4 b, d;
    gregory_bern3(t, b, d);
    return p0 * b.x + p1 * b.y + p2 * b.z + p3 * b.w;
}
#endif
