// The generalized winding number's f64 kernels, operation for operation those of src/voxel/gwn.rs: every
// intermediate `precise` (no fused multiply-add), no built-in dot/cross/length (their order is the driver's),
// atan written out (GLSL has no double-precision atan). Add, subtract, multiply, divide and sqrt are
// correctly rounded on the devices that pass the tests, so the GPU and the CPU find the same voxels and the
// same winding numbers.
#ifndef GREGVOX_GWN_GLSL
#define GREGVOX_GWN_GLSL

// A cap triangle in grid-local world coordinates (CapTriangle in src/voxel/gwn.rs): a.w is the length of its
// boundary edge a-b, b.w the radius of a ball round its centroid that holds it.
struct CapTriangle {
    dvec4 a;
    dvec4 b;
    dvec4 c;
};

// A voxel the cap-term pass lists (Listed in src/voxel/gwn.rs): xyz the voxel, w 1 for a direct voxel (near
// the cap), 0 for a crossing voxel; w_cap.x the cap term.
struct GwnListed {
    uvec4 voxel;
    dvec2 w_cap;
};

const double GWN_FOUR_PI = 12.566370614359172lf;
const double GWN_PI = 3.141592653589793lf;
const double GWN_FRAC_PI_2 = 1.5707963267948966lf;
const double GWN_FRAC_PI_4 = 0.7853981633974483lf;
const double GWN_MARGIN = 1e-6lf;
const uint GWN_CELL = 2u;
const uint GWN_SPLIT = 2u;

dvec3 gwn_sub(dvec3 a, dvec3 b) {
    precise double x = a.x - b.x;
    precise double y = a.y - b.y;
    precise double z = a.z - b.z;
    return dvec3(x, y, z);
}

dvec3 gwn_cross(dvec3 a, dvec3 b) {
    precise double x = a.y * b.z - a.z * b.y;
    precise double y = a.z * b.x - a.x * b.z;
    precise double z = a.x * b.y - a.y * b.x;
    return dvec3(x, y, z);
}

double gwn_dot(dvec3 a, dvec3 b) {
    precise double r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}

double gwn_norm(dvec3 a) {
    precise double r = sqrt(gwn_dot(a, a));
    return r;
}

// Cephes' atan (src/voxel/gwn.rs::atan_f64).
double gwn_atan(double x_in) {
    const double P0 = -8.750608600031904122785e-1lf;
    const double P1 = -1.615753718733365076637e1lf;
    const double P2 = -7.500855792314704667340e1lf;
    const double P3 = -1.228866684490136173410e2lf;
    const double P4 = -6.485021904942025371773e1lf;
    const double Q0 = 2.485846490142306297962e1lf;
    const double Q1 = 1.650270098316988542046e2lf;
    const double Q2 = 4.328810604912902668951e2lf;
    const double Q3 = 4.853903996359136964868e2lf;
    const double Q4 = 1.945506571482613964425e2lf;
    const double MOREBITS = 6.123233995736765886130e-17lf;
    const double T3P8 = 2.41421356237309504880lf;
    bool negative = x_in < 0.0lf;
    precise double x = abs(x_in);
    double y0 = 0.0lf;
    double more = 0.0lf;
    if (x > T3P8) {
        x = -1.0lf / x;
        y0 = GWN_FRAC_PI_2;
        more = MOREBITS;
    } else if (x <= 0.66lf) {
        y0 = 0.0lf;
        more = 0.0lf;
    } else {
        x = (x - 1.0lf) / (x + 1.0lf);
        y0 = GWN_FRAC_PI_4;
        more = 0.5lf * MOREBITS;
    }
    precise double z = x * x;
    precise double p = (((P0 * z + P1) * z + P2) * z + P3) * z + P4;
    precise double q = ((((z + Q0) * z + Q1) * z + Q2) * z + Q3) * z + Q4;
    precise double r = z * p / q;
    precise double r2 = x * r + x;
    precise double y = y0 + (r2 + more);
    return negative ? -y : y;
}

double gwn_atan2(double y, double x) {
    if (x > 0.0lf) {
        return gwn_atan(y / x);
    } else if (x < 0.0lf) {
        precise double r = (y >= 0.0lf) ? gwn_atan(y / x) + GWN_PI : gwn_atan(y / x) - GWN_PI;
        return r;
    } else if (y > 0.0lf) {
        return GWN_FRAC_PI_2;
    } else if (y < 0.0lf) {
        return -GWN_FRAC_PI_2;
    }
    return 0.0lf;
}

// Signed solid angle of (a, b, c) seen from p (Van Oosterom & Strackee).
double gwn_solid_angle(dvec3 p, dvec3 a_in, dvec3 b_in, dvec3 c_in) {
    dvec3 a = gwn_sub(a_in, p), b = gwn_sub(b_in, p), c = gwn_sub(c_in, p);
    double la = gwn_norm(a), lb = gwn_norm(b), lc = gwn_norm(c);
    precise double det = gwn_dot(a, gwn_cross(b, c));
    precise double den = la * lb * lc + gwn_dot(a, b) * lc + gwn_dot(a, c) * lb + gwn_dot(b, c) * la;
    precise double r = 2.0lf * gwn_atan2(det, den);
    return r;
}

// The local centre of voxel ijk: (i + 1/2)·size.
dvec3 gwn_centre(uvec3 ijk, dvec3 size) {
    precise double x = (double(ijk.x) + 0.5lf) * size.x;
    precise double y = (double(ijk.y) + 0.5lf) * size.y;
    precise double z = (double(ijk.z) + 0.5lf) * size.z;
    return dvec3(x, y, z);
}

// Squared distance from p to the segment a-b (src/voxel/gwn.rs::segment_distance2).
double gwn_segment_distance2(dvec3 p, dvec3 a, dvec3 b) {
    dvec3 ab = gwn_sub(b, a), ap = gwn_sub(p, a);
    double l2 = gwn_dot(ab, ab);
    double t = 0.0lf;
    if (l2 > 0.0lf) {
        precise double q = gwn_dot(ap, ab) / l2;
        t = min(max(q, 0.0lf), 1.0lf);
    }
    precise double qx = a.x + t * ab.x;
    precise double qy = a.y + t * ab.y;
    precise double qz = a.z + t * ab.z;
    dvec3 d = gwn_sub(p, dvec3(qx, qy, qz));
    return gwn_dot(d, d);
}

// Distance from p to cap triangle t (src/voxel/gwn.rs::triangle_distance).
double gwn_triangle_distance(dvec3 p, CapTriangle t) {
    dvec3 a = t.a.xyz, b = t.b.xyz, c = t.c.xyz;
    dvec3 n = gwn_cross(gwn_sub(b, a), gwn_sub(c, a));
    double nn = gwn_dot(n, n);
    if (nn > 0.0lf
        && gwn_dot(gwn_cross(gwn_sub(b, a), gwn_sub(p, a)), n) >= 0.0lf
        && gwn_dot(gwn_cross(gwn_sub(c, b), gwn_sub(p, b)), n) >= 0.0lf
        && gwn_dot(gwn_cross(gwn_sub(a, c), gwn_sub(p, c)), n) >= 0.0lf) {
        precise double r = abs(gwn_dot(n, gwn_sub(p, a))) / sqrt(nn);
        return r;
    }
    precise double m = min(min(gwn_segment_distance2(p, a, b), gwn_segment_distance2(p, b, c)),
                           gwn_segment_distance2(p, c, a));
    precise double r = sqrt(m);
    return r;
}

// Within `near` of t: its plane and box grown by `near` first, then the exact distance
// (src/voxel/gwn.rs::near_triangle).
bool gwn_near_triangle(dvec3 p, CapTriangle t, double near) {
    dvec3 a = t.a.xyz, b = t.b.xyz, c = t.c.xyz;
    dvec3 n = gwn_cross(gwn_sub(b, a), gwn_sub(c, a));
    precise double nn = gwn_dot(n, n);
    if (nn == 0.0lf) return false;
    precise double s = gwn_dot(n, gwn_sub(p, a));
    precise double ss = s * s;
    precise double lim = near * near * nn;
    if (ss >= lim) return false;
    for (int k = 0; k < 3; ++k) {
        precise double lo = min(min(a[k], b[k]), c[k]) - near;
        precise double hi = max(max(a[k], b[k]), c[k]) + near;
        if (!(p[k] >= lo && p[k] <= hi)) return false;
    }
    return gwn_triangle_distance(p, t) <= near;
}

// A lower bound on the distance from p to t: to its ball (src/voxel/gwn.rs::ball_distance).
double gwn_ball_distance(dvec3 p, CapTriangle t) {
    precise double mx = (t.a.x + t.b.x + t.c.x) / 3.0lf;
    precise double my = (t.a.y + t.b.y + t.c.y) / 3.0lf;
    precise double mz = (t.a.z + t.b.z + t.c.z) / 3.0lf;
    precise double r = gwn_norm(gwn_sub(p, dvec3(mx, my, mz))) - t.b.w;
    return r;
}

// The distance bound past r of the box test (src/voxel/gwn.rs::box_needs_cap_term's `gap`).
double gwn_gap(dvec3 c, double r, CapTriangle t, double near) {
    precise double g = gwn_ball_distance(c, t) - r;
    precise double lim = 4.0lf * t.b.w + near;
    if (g <= lim) {
        precise double e = gwn_triangle_distance(c, t) - r;
        return e;
    }
    return g;
}
#endif