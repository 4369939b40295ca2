// The Beziex patch (docs/notes/gregory.md §5): S = (u(1−u)·Ra + v(1−v)·Rb) / (u(1−u) + v(1−v)), Ra of bidegree
// (6, 3) and Rb of bidegree (3, 6) from 56 points (Ra rows then Rb columns, 7 points each; see
// gregvox::surface::beziex). At the corners S = Ra. Mirrors BeziexPatch::eval.
#ifndef GREGVOX_BEZIEX_GLSL
#define GREGVOX_BEZIEX_GLSL
const float BEZIEX_CORNER_EPS = 1e-6;

void beziex_bern6(float t, out float b[7], out float d[7]) {
    float s = 1.0 - t;
    float c[7] = float[7](1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0);
    float tp[7], sp[7];
    tp[0] = 1.0; sp[0] = 1.0;
    for (int k = 1; k < 7; ++k) { tp[k] = tp[k - 1] * t; sp[k] = sp[k - 1] * s; }
    for (int k = 0; k < 7; ++k) {
        b[k] = c[k] * tp[k] * sp[6 - k];
        float left = k > 0 ? float(k) * tp[k - 1] * sp[6 - k] : 0.0;
        float right = k < 6 ? float(6 - k) * tp[k] * sp[5 - k] : 0.0;
        d[k] = c[k] * (left - right);
    }
}

void beziex_bern3(float t, out vec4 b, out vec4 d) {
    float s = 1.0 - t;
    b = vec4(s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t);
    d = vec4(-3.0 * s * s, 3.0 * s * s - 6.0 * t * s, 6.0 * t * s - 3.0 * t * t, 3.0 * t * t);
}

// net[0..28): Ra rows, net[28..56): Rb columns.
void beziex_eval(in vec3 net[56], float u, float v, out vec3 p, out vec3 su, out vec3 sv) {
    u = clamp(u, 0.0, 1.0);
    v = clamp(v, 0.0, 1.0);
    float b6u[7], d6u[7], b6v[7], d6v[7];
    beziex_bern6(u, b6u, d6u);
    beziex_bern6(v, b6v, d6v);
    vec4 b3u, d3u, b3v, d3v;
    beziex_bern3(u, b3u, d3u);
    beziex_bern3(v, b3v, d3v);
    vec3 ra = vec3(0.0), ra_u = vec3(0.0), ra_v = vec3(0.0);
    vec3 rb = vec3(0.0), rb_u = vec3(0.0), rb_v = vec3(0.0);
    for (int j = 0; j < 4; ++j) {
        vec3 row = vec3(0.0), row_u = vec3(0.0), col = vec3(0.0), col_v = vec3(0.0);
        for (int k = 0; k < 7; ++k) {
            row += net[7 * j + k] * b6u[k];
            row_u += net[7 * j + k] * d6u[k];
            col += net[28 + 7 * j + k] * b6v[k];
            col_v += net[28 + 7 * j + k] * d6v[k];
        }
        ra += row * b3v[j];
        ra_u += row_u * b3v[j];
        ra_v += row * d3v[j];
        rb += col * b3u[j];
        rb_u += col * d3u[j];
        rb_v += col_v * b3u[j];
    }
    bool nu = u < BEZIEX_CORNER_EPS || u > 1.0 - BEZIEX_CORNER_EPS;
    bool nv = v < BEZIEX_CORNER_EPS || v > 1.0 - BEZIEX_CORNER_EPS;
    if (nu && nv) {
        p = ra; su = ra_u; sv = ra_v;
        return;
    }
    float pu = u * (1.0 - u), pv = v * (1.0 - v);
    float dpu = 1.0 - 2.0 * u, dpv = 1.0 - 2.0 * v;
    float d = pu + pv;
    vec3 n = ra * pu + rb * pv;
    vec3 n_u = ra * dpu + ra_u * pu + rb_u * pv;
    vec3 n_v = ra_v * pu + rb * dpv + rb_v * pv;
    float inv = 1.0 / d;
    p = n * inv;
    su = (n_u * d - n * dpu) * (inv * inv);
    sv = (n_v * d - n * dpv) * (inv * inv);
}

// x / |x|, or 0 for x = 0. Scaled first by the power of two that brings its largest component into
// [1/2, 1) (frexp, exact): |x|² of a 1e-20-sized derivative would underflow to 0, of a 1e20-sized one
// overflow.
vec3 beziex_unit(vec3 x) {
    float m = max(abs(x.x), max(abs(x.y), abs(x.z)));
    if (!(m > 0.0) || isinf(m)) return vec3(0.0);
    int e;
    frexp(m, e);
    return normalize(ldexp(x, ivec3(-e)));
}

vec3 beziex_normal(vec3 su, vec3 sv) {
    vec3 a = beziex_unit(su);
    vec3 b = beziex_unit(sv);
    vec3 n = cross(a, b);
    float l = length(n);
    return l > 0.0 ? n / l : vec3(0.0, 0.0, 1.0);
}
#endif
