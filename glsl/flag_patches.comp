#version 460
// The thesis's flag experiment (Takeda 2008 §3.1.1): a C×R grid of Gregory patches interpolating an animated
// network of boundary cubics (a flag waving from a pole). One invocation per patch writes its 20 control points
// (GREGORY_BASIS order) at points[20·patch].
// Network: corner (c, r) sits at a slightly skewed grid position (x, y) with height z = f(x, y, t) (the wave);
// the cubic from corner a to corner b has inner points a + T(a, b − a)/3 and b + T(b, a − b)/3 with
// T(p, d) = (d.x, d.y, f_x(p)·d.x + f_y(p)·d.y), so all curves at a corner share its tangent plane.
// Face points: zero twist (F = Ep + Em − P) on the flag's outer edges, and on shared edges either the same
// (correction off: not G1, since the skewed grid makes the two sides' cross-boundary fields disagree) or the
// Chiyokura–Kimura correction (eqs. 2.10–2.12), computed identically by both patches from the network
// (A = the patch with the lower index). Mirrors gregvox::engine::flag::flag_patches (f64).
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Points { vec4 points[]; };
// Per corner of the network ((columns + 1) × (rows + 1), row-major): a user's move of the corner (the demo
// drags them), xy added to its grid position, z to its height; all zero for the thesis's flag.
layout(std430, set = 0, binding = 1) readonly buffer Offsets { vec4 offsets[]; };
layout(push_constant) uniform Push {
    uint columns;
    uint rows;
    uint correct;     // 1: Chiyokura–Kimura on shared edges
    uint pad;
    float t;
    float amplitude;
} pc;

vec4 offset(ivec2 g) {
    bool inside = g.x >= 0 && g.y >= 0 && g.x <= int(pc.columns) && g.y <= int(pc.rows);
    return inside ? offsets[g.y * int(pc.columns + 1u) + g.x] : vec4(0.0);
}
vec2 grid_xy(ivec2 g) {
    float c = float(g.x), r = float(g.y);
    return vec2(c + 0.15 * sin(1.3 * c + 2.1 * r + 0.4), r + 0.15 * sin(0.7 * c + 1.9 * r + 1.1))
        + offset(g).xy;
}
float phase(vec2 p) { return 2.0 * p.x - 3.0 * pc.t + 0.6 * p.y; }
vec3 corner(ivec2 g) {
    vec2 p = grid_xy(g);
    return vec3(p, pc.amplitude * (p.x / float(pc.columns)) * sin(phase(p)) + offset(g).z);
}
// Inner point near corner a of the cubic from a to b.
vec3 near_point(ivec2 a, ivec2 b) {
    vec2 p = grid_xy(a);
    vec2 d = grid_xy(b) - p;
    float w = float(pc.columns);
    float ph = phase(p);
    float fx = pc.amplitude * (sin(ph) / w + (p.x / w) * 2.0 * cos(ph));
    float fy = pc.amplitude * (p.x / w) * 0.6 * cos(ph);
    return corner(a) + vec3(d, fx * d.x + fy * d.y) / 3.0;
}
// Least squares b ≈ k·a + h·c (eq. 2.12).
vec2 solve2(vec3 a, vec3 c, vec3 b) {
    float aa = dot(a, a), ac = dot(a, c), cc = dot(c, c);
    float det = aa * cc - ac * ac;
    if (!(det > 1e-12 * aa * cc)) return vec2(0.0);
    float ab = dot(a, b), cb = dot(c, b);
    return vec2((ab * cc - cb * ac) / det, (aa * cb - ac * ab) / det);
}

// Edge e (0 V0, 1 U1, 2 V1, 3 U0) of a patch: start and end corner (parameter increasing) and the indices of
// its two face points (geom::compat::Edge::inner()[1..3]).
const ivec2 EDGE_CORNERS[4] = ivec2[4](ivec2(0, 1), ivec2(1, 2), ivec2(3, 2), ivec2(0, 3));
const ivec2 EDGE_FACE[4] = ivec2[4](ivec2(3, 9), ivec2(8, 14), ivec2(19, 13), ivec2(4, 18));
const ivec2 CORNER_OFFSET[4] = ivec2[4](ivec2(0, 0), ivec2(1, 0), ivec2(1, 1), ivec2(0, 1));

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.columns * pc.rows) return;
    ivec2 g = ivec2(int(id % pc.columns), int(id / pc.columns));
    ivec2 C[4];
    for (int i = 0; i < 4; ++i) C[i] = g + CORNER_OFFSET[i];
    vec3 cv[20];
    for (int i = 0; i < 4; ++i) {
        vec3 p = corner(C[i]);
        vec3 ep = near_point(C[i], C[(i + 1) % 4]);
        vec3 em = near_point(C[i], C[(i + 3) % 4]);
        cv[5 * i] = p;
        cv[5 * i + 1] = ep;
        cv[5 * i + 2] = em;
        cv[5 * i + 3] = ep + em - p;
        cv[5 * i + 4] = ep + em - p;
    }
    if (pc.correct == 1u) {
        // Across edge e, this patch's interior lies towards `inward`, the neighbour's the other way.
        const ivec2 INWARD[4] = ivec2[4](ivec2(0, 1), ivec2(-1, 0), ivec2(0, -1), ivec2(1, 0));
        for (int e = 0; e < 4; ++e) {
            ivec2 nb = g - INWARD[e];
            if (nb.x < 0 || nb.y < 0 || nb.x >= int(pc.columns) || nb.y >= int(pc.rows)) continue;
            ivec2 s = C[EDGE_CORNERS[e].x], f = C[EDGE_CORNERS[e].y];
            vec3 p0 = corner(s), p1 = near_point(s, f), p2 = near_point(f, s), p3 = corner(f);
            bool me_a = int(id) < nb.y * int(pc.columns) + nb.x;
            ivec2 in_a = me_a ? INWARD[e] : -INWARD[e];
            vec3 a0 = near_point(s, s + in_a) - p0, a3 = near_point(f, f + in_a) - p3;
            vec3 b0 = near_point(s, s - in_a) - p0, b3 = near_point(f, f - in_a) - p3;
            vec3 c0 = p1 - p0, c1 = p2 - p1, c2 = p3 - p2;
            vec2 kh0 = solve2(a0, c0, b0), kh1 = solve2(a3, c2, b3);
            float k0 = kh0.x, h0 = kh0.y, k1 = kh1.x, h1 = kh1.y;
            vec3 a1 = (a0 * 2.0 + a3) / 3.0;
            vec3 a2 = (a0 + a3 * 2.0) / 3.0;
            vec3 f1, f2;
            if (me_a) {
                f1 = p1 + a1;
                f2 = p2 + a2;
            } else {
                f1 = p1 + ((k1 - k0) * a0 + 3.0 * k0 * a1 + 2.0 * h0 * c1 + h1 * c0) / 3.0;
                f2 = p2 + (3.0 * k1 * a2 - (k1 - k0) * a3 + h0 * c2 + 2.0 * h1 * c1) / 3.0;
            }
            cv[EDGE_FACE[e].x] = f1;
            cv[EDGE_FACE[e].y] = f2;
        }
    }
    for (int k = 0; k < 20; ++k) points[20u * id + uint(k)] = vec4(cv[k], 1.0);
}
