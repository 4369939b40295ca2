// The bicubic Gregory patch (20 control points, OpenSubdiv GREGORY_BASIS order), evaluated with exact
// partial derivatives, the corner 0/0 guard and the degenerate-normal fallback. It mirrors
// gregvox::geom::gregory::eval_generic operation for operation (see that function's steps) on the patch-local
// points cv − cv[0], so the f32 CPU mirror of the localized patch (plus cv[0]) is the
// reference for the GPU. Shared by gregory_eval.comp and the vertex-pull path.
#ifndef GREGVOX_GREGORY_GLSL
#define GREGVOX_GREGORY_GLSL

const float GREGORY_CORNER_EPS = 1e-6;

// Bézier grid [row = v][col = u] (geom::gregory::BEZIER_GRID): row 0: 0 1 7 5; row 1: 2 Q11 Q21 6;
// row 2: 16 Q12 Q22 12; row 3: 15 17 11 10, with Q11 = (3, 4), Q21 = (9, 8), Q12 = (19, 18), Q22 = (13, 14).

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

// One row of the net contracted with weights w: ((a·w.x + b·w.y) + c·w.z) + d·w.w, the CPU's order.
vec3 gregory_row(vec3 a, vec3 b, vec3 c, vec3 d, vec4 w) {
    return a * w.x + b * w.y + c * w.z + d * w.w;
}

// Position and exact first partials at (u, v) ∈ [0,1]²; also returns the frozen net (local) for the normal
// fallback. `cv` are the control points relative to `origin` (patch-local coordinates, see gregory_eval):
// the position is the local one plus `origin`.
// Written out without loops or dynamic indexing: llvmpipe keeps every value in registers.
void gregory_eval_local(in vec3 cv[20], vec3 origin, float u, float v, out vec3 p, out vec3 su, out vec3 sv,
                        out vec3 net[16]) {
    u = clamp(u, 0.0, 1.0);
    v = clamp(v, 0.0, 1.0);
    vec4 bu, du, bv, dv;
    gregory_bern3(u, bu, du);
    gregory_bern3(v, bv, dv);
    float uu = 1.0 - u, vv = 1.0 - v;
    vec3 q11, q21, q12, q22, u11, v11, u21, v21, u12, v12, u22, v22;
    // Interior cells in the order Q11 (1,1), Q21 (2,1), Q12 (1,2), Q22 (2,2).
    gregory_rational(cv[3], cv[4], u, v, 1.0, 1.0, q11, u11, v11);
    gregory_rational(cv[9], cv[8], uu, v, -1.0, 1.0, q21, u21, v21);
    gregory_rational(cv[19], cv[18], u, vv, 1.0, -1.0, q12, u12, v12);
    gregory_rational(cv[13], cv[14], uu, vv, -1.0, -1.0, q22, u22, v22);
    net[0] = cv[0];  net[1] = cv[1];  net[2] = cv[7];  net[3] = cv[5];
    net[4] = cv[2];  net[5] = q11;    net[6] = q21;    net[7] = cv[6];
    net[8] = cv[16]; net[9] = q12;    net[10] = q22;   net[11] = cv[12];
    net[12] = cv[15]; net[13] = cv[17]; net[14] = cv[11]; net[15] = cv[10];
    vec3 r0 = gregory_row(cv[0], cv[1], cv[7], cv[5], bu);
    vec3 r1 = gregory_row(cv[2], q11, q21, cv[6], bu);
    vec3 r2 = gregory_row(cv[16], q12, q22, cv[12], bu);
    vec3 r3 = gregory_row(cv[15], cv[17], cv[11], cv[10], bu);
    vec3 d0 = gregory_row(cv[0], cv[1], cv[7], cv[5], du);
    vec3 d1 = gregory_row(cv[2], q11, q21, cv[6], du);
    vec3 d2 = gregory_row(cv[16], q12, q22, cv[12], du);
    vec3 d3 = gregory_row(cv[15], cv[17], cv[11], cv[10], du);
    p = gregory_row(r0, r1, r2, r3, bv) + origin;
    su = gregory_row(d0, d1, d2, d3, bv);
    sv = gregory_row(r0, r1, r2, r3, dv);
    // Exact-derivative correction: Σ B_i(u) B_j(v) ∂Q_ij over the interior cells.
    su = su + u11 * (bu.y * bv.y); sv = sv + v11 * (bu.y * bv.y);
    su = su + u21 * (bu.z * bv.y); sv = sv + v21 * (bu.z * bv.y);
    su = su + u12 * (bu.y * bv.z); sv = sv + v12 * (bu.y * bv.z);
    su = su + u22 * (bu.z * bv.z); sv = sv + v22 * (bu.z * bv.z);
}

// Patch-local coordinates: the points relative to the patch's first corner. The derivatives are Bernstein sums
// whose weights cancel (Σ B' = 0); summed in world coordinates their f32 error scales with |P| (the distance
// from the world origin), in local ones with the patch size: on spot (|P| ≈ 0.5, patches ≈ 0.03 wide) that
// is ~20× less normal error, which decides G1 at folds where S_u and S_v are nearly parallel.
void gregory_localize(in vec3 cv[20], out vec3 local[20]) {
    for (int k = 0; k < 20; ++k) local[k] = cv[k] - cv[0];
}

// gregory_eval_local on world-space points.
void gregory_eval(in vec3 cv[20], float u, float v, out vec3 p, out vec3 su, out vec3 sv, out vec3 net[16]) {
    vec3 local[20];
    gregory_localize(cv, local);
    gregory_eval_local(local, cv[0], u, v, p, su, sv, net);
}

// a and b times one power of two bringing their largest component into [1/2, 1) (frexp): exact, so every
// test and unit vector keeps its bits, while cross products of 1e-20- or 1e20-sized vectors neither
// underflow nor overflow. Mirrors geom::gregory's `rescaled`.
void pow2_rescale(inout vec3 a, inout vec3 b) {
    vec3 m3 = max(abs(a), abs(b));
    float m = max(m3.x, max(m3.y, m3.z));
    if (m > 0.0 && !isinf(m) && !isnan(m)) {
        int e;
        frexp(m, e);
        a = ldexp(a, ivec3(-e));
        b = ldexp(b, ivec3(-e));
    }
}

// Unit normal with the fallback of geom::gregory (notes §1.5): S_u × S_v unless degenerate, then the
// diagonals of the de Casteljau bilinear hull, then the corner diagonals, then +Z. Never NaN.
vec3 gregory_normal(in vec3 net[16], vec3 su, vec3 sv, float u, float v) {
    pow2_rescale(su, sv);
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
    vec3 d0 = c[3] - c[0], d1 = c[1] - c[2];
    pow2_rescale(d0, d1);
    vec3 hull = cross(d0, d1);
    float lh = length(hull);
    if (lh > 0.0 && !isinf(lh)) return hull / lh;
    vec3 e0 = net[15] - net[0], e1 = net[12] - net[3];
    pow2_rescale(e0, e1);
    vec3 corners = cross(e0, e1);
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
