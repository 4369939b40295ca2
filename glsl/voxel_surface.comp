#version 460
// Surface voxels: every voxel whose closed box a triangle touches (Akenine-Möller's separating-axis test).
// The CPU lists the work (`engine::voxelize::surface_work`): per triangle, its dominant axis d (the largest
// component of its normal) and the box of columns across d that its extent touches; one invocation per
// (triangle, column) finds its entry by binary search, walks the few voxels along d that the triangle's plane
// spans over the column (at most five: |n_d| is the largest component) and marks, with atomicOr, those the
// test accepts in the rows [row0, row0 + rows) of a bit grid with bits along z (word ((j - row0)·X + i)·W +
// k/32). Work per invocation stays small on any triangle (lavapipe also cuts loops past 65,535 iterations).
// The test mirrors src/voxel/surface.rs operation for operation in f64, every intermediate `precise` (no
// fused multiply-add) and no built-in dot/cross (their order is the driver's), so the GPU and the CPU mark
// the same voxels bit for bit: add, subtract and multiply are correctly rounded in Vulkan; the one division
// only bounds the walk, which is widened by a voxel each way.
#include "dispatch.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Vertices { float pos[]; };
layout(std430, set = 0, binding = 1) readonly buffer Indices { uint idx[]; };
layout(std430, set = 0, binding = 2) buffer Bits { uint bits[]; };
// One entry per triangle with work, in order of `first` (SurfaceWork in src/passes/voxel_surface.rs).
struct Work {
    uint first;    // first invocation of this triangle
    uint tri;      // triangle index
    uint axis;     // the walk axis d
    uint a0;       // first column along axis (d+1)%3
    uint b0;       // first column along axis (d+2)%3
    uint na;       // columns along (d+1)%3
    uint full;     // 1: walk the triangle's whole extent along d (a degenerate normal)
    uint pad;
};
layout(std430, set = 0, binding = 3) readonly buffer Works { Work works[]; };
layout(push_constant) uniform Push {
    dvec4 origin;         // xyz: grid origin
    dvec4 inv_size;       // xyz: 1 / voxel size
    uvec4 dims;           // xyz: voxels per axis, w: words per column (ceil(Z/32))
    uint work_count;
    uint invocations;     // sum of the columns of every entry
    uint row0;            // first row j of this slab
    uint rows;            // rows in this slab
} pc;

dvec3 sub3(dvec3 a, dvec3 b) {
    precise dvec3 r = dvec3(a.x - b.x, a.y - b.y, a.z - b.z);
    return r;
}

dvec3 cross3(dvec3 a, dvec3 b) {
    precise double x = a.y * b.z - a.z * b.y;
    precise double y = a.z * b.x - a.x * b.z;
    precise double z = a.x * b.y - a.y * b.x;
    return dvec3(x, y, z);
}

double dot3(dvec3 a, dvec3 b) {
    precise double r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}

bool separates(dvec3 n, dvec3 v0, dvec3 v1, dvec3 v2, double h) {
    precise double p0 = dot3(n, v0);
    precise double p1 = dot3(n, v1);
    precise double p2 = dot3(n, v2);
    double lo = min(min(p0, p1), p2);
    double hi = max(max(p0, p1), p2);
    precise double r = h * (abs(n.x) + abs(n.y) + abs(n.z));
    return lo > r || hi < -r;
}

bool triangle_box_overlap(dvec3 c, double h, dvec3 t0, dvec3 t1, dvec3 t2) {
    dvec3 v0 = sub3(t0, c), v1 = sub3(t1, c), v2 = sub3(t2, c);
    for (int a = 0; a < 3; ++a) {
        double lo = min(min(v0[a], v1[a]), v2[a]);
        double hi = max(max(v0[a], v1[a]), v2[a]);
        if (lo > h || hi < -h) return false;
    }
    dvec3 e[3] = dvec3[3](sub3(v1, v0), sub3(v2, v1), sub3(v0, v2));
    for (int m = 0; m < 3; ++m) {
        for (int a = 0; a < 3; ++a) {
            dvec3 axis = dvec3(0.0);
            axis[a] = 1.0;
            dvec3 n = cross3(e[m], axis);
            if (n == dvec3(0.0)) continue;
            if (separates(n, v0, v1, v2, h)) return false;
        }
    }
    dvec3 n = cross3(e[0], e[1]);
    return n == dvec3(0.0) || !separates(n, v0, v1, v2, h);
}

// Voxel indices [i0, i1] along `axis` whose closed boxes the triangle's extent touches; false if none.
bool touched(dvec3 t0, dvec3 t1, dvec3 t2, int axis, uint n, out uint i0, out uint i1) {
    double lo = min(min(t0[axis], t1[axis]), t2[axis]);
    double hi = max(max(t0[axis], t1[axis]), t2[axis]);
    precise double lo1 = lo - 1.0;
    double a = max(ceil(lo1), 0.0);
    precise double top = double(n) - 1.0;
    double b = min(floor(hi), top);
    if (a > b) return false;
    i0 = uint(a);
    i1 = uint(b);
    return true;
}

dvec3 grid_point(uint v) {
    dvec3 p = dvec3(double(pos[3u * v]), double(pos[3u * v + 1u]), double(pos[3u * v + 2u]));
    precise dvec3 g = dvec3((p.x - pc.origin.x) * pc.inv_size.x, (p.y - pc.origin.y) * pc.inv_size.y,
                            (p.z - pc.origin.z) * pc.inv_size.z);
    return g;
}

void main() {
    uint inv = linear_invocation();
    if (inv >= pc.invocations) return;
    uint lo = 0u, hi = pc.work_count - 1u;
    while (lo < hi) {
        uint mid = (lo + hi + 1u) / 2u;
        if (works[mid].first <= inv) lo = mid; else hi = mid - 1u;
    }
    Work w = works[lo];
    uint local = inv - w.first;
    int d = int(w.axis), a = (d + 1) % 3, b = (d + 2) % 3;
    uint ia = w.a0 + local % w.na, ib = w.b0 + local / w.na;
    dvec3 t0 = grid_point(idx[3u * w.tri]);
    dvec3 t1 = grid_point(idx[3u * w.tri + 1u]);
    dvec3 t2 = grid_point(idx[3u * w.tri + 2u]);
    uint k0, k1;
    if (!touched(t0, t1, t2, d, pc.dims[d], k0, k1)) return;
    uint ka = k0, kb = k1;
    if (w.full == 0u) {
        dvec3 n = cross3(sub3(t1, t0), sub3(t2, t0));
        double zlo = 1.0e300, zhi = -1.0e300;
        for (int c = 0; c < 4; ++c) {
            precise double ca = double(ia) + double(c & 1) - t0[a];
            precise double cb = double(ib) + double(c >> 1) - t0[b];
            precise double z = t0[d] - (n[a] * ca + n[b] * cb) / n[d];
            zlo = min(zlo, z);
            zhi = max(zhi, z);
        }
        precise double za = floor(zlo) - 1.0;
        precise double zb = floor(zhi) + 1.0;
        double lo_d = max(za, double(k0));
        double hi_d = min(zb, double(k1));
        if (lo_d > hi_d) return;
        ka = uint(lo_d);
        kb = uint(hi_d);
    }
    for (uint k = ka; k <= kb; ++k) {
        uvec3 v;
        v[a] = ia;
        v[b] = ib;
        v[d] = k;
        if (v.y < pc.row0 || v.y >= pc.row0 + pc.rows) continue;
        precise dvec3 c = dvec3(double(v.x) + 0.5, double(v.y) + 0.5, double(v.z) + 0.5);
        if (triangle_box_overlap(c, 0.5, t0, t1, t2)) {
            uint base = ((v.y - pc.row0) * pc.dims.x + v.x) * pc.dims.w;
            atomicOr(bits[base + (v.z >> 5)], 1u << (v.z & 31u));
        }
    }
}
