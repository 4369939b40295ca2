// Shared by the OpenSubdiv peers of `gregvox bench` (osd_eval_bench.cpp, osd_glcompute_bench.cpp): the
// point types Far's stencil and patch evaluation fill, and the all-quad OBJ cage reader with its checks
// (missing file, a face that is not a quad, no faces, an index out of range: one line on stderr, false).
#pragma once
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

struct V3 {
    double p[3];
    void Clear(void * = 0) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(V3 const &s, double w) { for (int k = 0; k < 3; ++k) p[k] += w * s.p[k]; }
};

struct V3f {
    float p[3];
    void Clear(void * = 0) { p[0] = p[1] = p[2] = 0; }
    void AddWithWeight(V3f const &s, float w) { for (int k = 0; k < 3; ++k) p[k] += w * s.p[k]; }
};
static_assert(sizeof(V3f) == 3 * sizeof(float), "a buffer of x, y, z floats");

// Reads the `v` and `f` lines of an OBJ (negative indices relative, texture/normal indices ignored) into
// positions, vertices per face and 0-based face indices; false (after one stderr line) unless it is a
// non-empty all-quad cage whose indices are in range.
static bool read_quad_cage(const char *path, std::vector<V3> &pos, std::vector<int> &nv, std::vector<int> &idx) {
    std::ifstream in(path);
    if (!in) { fprintf(stderr, "%s: cannot open\n", path); return false; }
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ss(line);
        std::string tag;
        ss >> tag;
        if (tag == "v") { V3 v; ss >> v.p[0] >> v.p[1] >> v.p[2]; pos.push_back(v); }
        else if (tag == "f") {
            std::string tok; int n = 0;
            while (ss >> tok) { int i = atoi(tok.c_str()); if (i < 0) i = (int)pos.size() + i + 1; idx.push_back(i - 1); ++n; }
            nv.push_back(n);
        }
    }
    for (int n : nv) if (n != 4) { fprintf(stderr, "%s: not an all-quad cage\n", path); return false; }
    if (nv.empty()) { fprintf(stderr, "%s: no faces\n", path); return false; }
    for (int i : idx) if (i < 0 || i >= (int)pos.size()) { fprintf(stderr, "%s: face index out of range\n", path); return false; }
    return true;
}
