// The body of closest_point.comp and closest_point_ieee.comp (see closest_point.comp).
#include "dispatch.glsl"
layout(local_size_x = 64) in;
// Two rows per node: (lo.xyz, first) and (hi.xyz, count); a leaf has count > 0.
layout(std430, set = 0, binding = 0) readonly buffer Nodes { dvec4 node_rows[]; };
// Three rows (x, y, z, 0) per slot, in leaf order.
layout(std430, set = 0, binding = 1) readonly buffer Triangles { dvec4 corners[]; };
layout(std430, set = 0, binding = 2) readonly buffer Points { dvec4 points[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Slots { uint slots[]; };
// Each slot's triangle index (ties go to the lowest, as on the CPU).
layout(std430, set = 0, binding = 4) readonly buffer Index { uint triangle_index[]; };
layout(push_constant) uniform Push {
    uint count;
    uint visits;   // nodes one search visits at most (VISITS in src/passes/closest_point.rs)
    int perturb;   // tests only: ulps added to every quotient before its correction (0 in use)
    uint pad;
} pc;

// The traversal stack (`STACK` in src/passes/closest_point.rs; the host refuses deeper trees).
#define STACK 64

dvec3 sub3(dvec3 a, dvec3 b) {
    precise dvec3 r = dvec3(a.x - b.x, a.y - b.y, a.z - b.z);
    return r;
}

double dot3(dvec3 a, dvec3 b) {
    precise double r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}

// (lo − p).max(0).max(p − hi) squared and summed per axis, as `box_distance2` (no loop: see main).
double box_distance2(dvec3 p, dvec3 lo, dvec3 hi) {
    precise dvec3 l = lo - p;
    precise dvec3 h = p - hi;
    dvec3 d = max(max(l, dvec3(0.0)), h);
    precise double s = d.x * d.x + d.y * d.y + d.z * d.z;
    return s;
}

// Correctly rounded f64 division from operations Vulkan rounds correctly. Vulkan requires add, subtract
// and multiply to be correctly rounded in f64 but not division (only "at least single precision"), and
// the CPU's quotients are IEEE's: the driver's quotient is corrected here by its exact remainder. For
// positive A, B and q within a few ulps of A/B, p + e = q·B exactly (Dekker's product, Veltkamp's split: no
// fused multiply-add needed), A − p is exact (Sterbenz) and so is r = A − q·B; q is A/B rounded to nearest
// iff |r| ≤ ½ulp(q)·B (half the lower ulp when the exact quotient lies below a power of two), ties to the
// even mantissa. Three steps of one ulp are written out (a loop would count against lavapipe's limit).
// lavapipe divides with the CPU's own IEEE division: closest_point_ieee.comp leaves the correction out
// there (lavapipe runs every branch of a shader masked, so even unused it took 4× the search's time);
// the tests run this one on lavapipe with quotients perturbed by a few ulps. Quotients outside the normal range keep the
// driver's value (the closest-point weights are in [0, 1], far from it).
dvec2 two_product(double a, double b) {
    precise double p = a * b;
    precise double ca = 134217729.0 * a;
    precise double ah = ca - (ca - a);
    precise double al = a - ah;
    precise double cb = 134217729.0 * b;
    precise double bh = cb - (cb - b);
    precise double bl = b - bh;
    precise double e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    return dvec2(p, e);
}

double step_ulp(double q, bool up) {
    uvec2 u = unpackDouble2x32(q);
    if (up) {
        u.x += 1u;
        u.y += u.x == 0u ? 1u : 0u;
    } else {
        u.y -= u.x == 0u ? 1u : 0u;
        u.x -= 1u;
    }
    return packDouble2x32(u);
}

// One correction step: q, or its neighbour towards A/B when q is not A/B rounded to nearest.
double correct_step(double A, double B, double q) {
    uvec2 u = unpackDouble2x32(q);
    uint e = (u.y >> 20) & 0x7ffu;
    if (e < 60u || e > 2000u) return q;
    dvec2 pe = two_product(q, B);
    precise double r = (A - pe.x) - pe.y;
    // ½ulp(q)·B, a power of two times B.
    precise double h = packDouble2x32(uvec2(0u, (e - 53u) << 20)) * B;
    bool power_of_two = u.x == 0u && (u.y & 0xfffffu) == 0u;
    precise double below = power_of_two ? 0.5 * h : h;
    if (r > h || (r == h && (u.x & 1u) == 1u)) return step_ulp(q, true);
    if (-r > below || (-r == below && (u.x & 1u) == 1u)) return step_ulp(q, false);
    return q;
}

// q moved by k ulps (tests: a driver's quotient a few ulps off), without a loop.
double add_ulps(double q, int k) {
    uvec2 u = unpackDouble2x32(q);
    uint m = uint(abs(k));
    if (k > 0) {
        uint lo = u.x + m;
        u.y += lo < u.x ? 1u : 0u;
        u.x = lo;
    } else {
        u.y -= u.x < m ? 1u : 0u;
        u.x -= m;
    }
    return packDouble2x32(u);
}

#ifdef IEEE_DIVISION
// The driver divides as IEEE 754 does (closest_point_ieee.comp, for lavapipe).
double divide(double a, double b) {
    precise double q = a / b;
    return q;
}
#else
// a / b rounded to nearest, as the CPU divides (zero, infinite and NaN quotients as the driver gives them).
double divide(double a, double b) {
    precise double d = a / b;
    double A = abs(a), B = abs(b);
    double q = abs(d);
    if (!(q > 0.0) || !(B > 0.0) || isinf(q)) return d;
    if (pc.perturb != 0) q = add_ulps(q, pc.perturb);
    // Further steps only where the first moved q (never on an IEEE device).
    double q1 = correct_step(A, B, q);
    if (q1 != q) {
        q = correct_step(A, B, q1);
        if (q != q1) q = correct_step(A, B, q);
    }
    return (a < 0.0) != (b < 0.0) ? -q : q;
}
#endif

// `closest_on_triangle`: barycentric weights by Voronoi regions (Ericson §5.1.5).
dvec3 closest_weights(dvec3 p, dvec3 a, dvec3 b, dvec3 c) {
    dvec3 ab = sub3(b, a), ac = sub3(c, a), ap = sub3(p, a);
    double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return dvec3(1.0, 0.0, 0.0);
    dvec3 bp = sub3(p, b);
    double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return dvec3(0.0, 1.0, 0.0);
    precise double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        precise double den = d1 - d3;
        precise double v = den > 0.0 ? divide(d1, den) : 0.0;
        precise double u = 1.0 - v;
        return dvec3(u, v, 0.0);
    }
    dvec3 cp = sub3(p, c);
    double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return dvec3(0.0, 0.0, 1.0);
    precise double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        precise double den = d2 - d6;
        precise double w = den > 0.0 ? divide(d2, den) : 0.0;
        precise double u = 1.0 - w;
        return dvec3(u, 0.0, w);
    }
    precise double va = d3 * d6 - d5 * d4;
    precise double e43 = d4 - d3;
    precise double e56 = d5 - d6;
    if (va <= 0.0 && e43 >= 0.0 && e56 >= 0.0) {
        precise double den = e43 + e56;
        precise double w = den > 0.0 ? divide(e43, den) : 0.0;
        precise double u = 1.0 - w;
        return dvec3(0.0, u, w);
    }
    precise double sum = va + vb + vc;
    if (!(sum > 0.0)) {
        // A degenerate triangle whose regions all failed: its nearest corner (the first of equals).
        dvec3 pa = sub3(p, a), pb = sub3(p, b), pcc = sub3(p, c);
        double da = dot3(pa, pa), db = dot3(pb, pb), dc = dot3(pcc, pcc);
        if (da <= db && da <= dc) return dvec3(1.0, 0.0, 0.0);
        return db <= dc ? dvec3(0.0, 1.0, 0.0) : dvec3(0.0, 0.0, 1.0);
    }
    precise double v = divide(vb, sum);
    precise double w = divide(vc, sum);
    precise double u = 1.0 - v - w;
    return dvec3(u, v, w);
}

// `closest_point`'s squared distance: the point at the weights (w0·a + w1·b) + w2·c per axis, then |p − q|².
double piece_distance2(dvec3 p, uint s) {
    dvec3 a = corners[3u * s].xyz, b = corners[3u * s + 1u].xyz, c = corners[3u * s + 2u].xyz;
    dvec3 w = closest_weights(p, a, b, c);
    precise dvec3 q = dvec3(w.x * a.x + w.y * b.x + w.z * c.x, w.x * a.y + w.y * b.y + w.z * c.y,
                            w.x * a.z + w.y * b.z + w.z * c.z);
    dvec3 d = sub3(p, q);
    return dot3(d, d);
}

// pc.visits bounds the nodes one search visits. lavapipe ends every invocation's loops after 65,535
// iterations in all (gallivm's loop limiter counts down once per shader, across nested loops too: a loop
// over a leaf's pieces inside the traversal cut the fan of a 100,000-gon's searches short, farther than
// the CPU's answers), so the search has one loop, a leaf's pieces (at most 8, the CPU's
// `distance::LEAF`) are written out, and a search that reaches pc.visits nodes stops and says so: its best
// piece so far is still a good hint for the host's search, which finishes those points.
// The slot's high bit: the search stopped at pc.visits nodes.
#define INCOMPLETE 0x80000000u

void main() {
    uint q = linear_invocation();
    if (q >= pc.count) return;
    dvec3 p = points[q].xyz;
    uint stack_node[STACK];
    double stack_near[STACK];
    int top = 1;
    stack_node[0] = 0u;
    stack_near[0] = box_distance2(p, node_rows[0].xyz, node_rows[1].xyz);
    // Above every squared distance of f32 coordinates (at most ~10⁷⁸), as the CPU's +∞.
    double best = 1.0e300;
    uint best_slot = 0u;
    uint best_index = 0xffffffffu;
    uint visits = 0u;
    // (A `continue` in this loop miscompiled on lavapipe, Mesa 22.3: every branch falls through instead.)
    for (; visits < pc.visits && top > 0; ++visits) {
        top -= 1;
        uint i = stack_node[top];
        if (stack_near[top] <= best) {
            dvec4 r0 = node_rows[2u * i], r1 = node_rows[2u * i + 1u];
            uint first = uint(r0.w), count = uint(r1.w);
            if (count > 0u) {
#define PIECE(k)                                                                                 \
                if (k < count) {                                                                 \
                    uint s = first + k;                                                          \
                    double d2 = piece_distance2(p, s);                                           \
                    uint index = triangle_index[s];                                              \
                    if (d2 < best || (d2 == best && index < best_index)) {                       \
                        best = d2;                                                               \
                        best_slot = s;                                                           \
                        best_index = index;                                                      \
                    }                                                                            \
                }
                PIECE(0u) PIECE(1u) PIECE(2u) PIECE(3u) PIECE(4u) PIECE(5u) PIECE(6u) PIECE(7u)
            } else {
                uint a = first, b = first + 1u;
                double da = box_distance2(p, node_rows[2u * a].xyz, node_rows[2u * a + 1u].xyz);
                double db = box_distance2(p, node_rows[2u * b].xyz, node_rows[2u * b + 1u].xyz);
                bool a_first = da <= db;
                uint near_node = a_first ? a : b, far_node = a_first ? b : a;
                double near_d = a_first ? da : db, far_d = a_first ? db : da;
                // Nearer popped first; a child beyond the best so far never pushed.
                if (far_d <= best && top < STACK) {
                    stack_node[top] = far_node;
                    stack_near[top] = far_d;
                    top += 1;
                }
                if (near_d <= best && top < STACK) {
                    stack_node[top] = near_node;
                    stack_near[top] = near_d;
                    top += 1;
                }
            }
        }
    }
    slots[q] = best_slot | (top > 0 ? INCOMPLETE : 0u);
}
