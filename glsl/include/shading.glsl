// Lambert + ambient + Phong terms of the lecture notes, mirroring gregvox::geom::shading (the CPU reference).
#ifndef GREGVOX_SHADING_GLSL
#define GREGVOX_SHADING_GLSL
float shade_ambient(float ka, float ia) { return ka * ia; }
float shade_lambert(vec3 n, vec3 l) { return max(dot(n, l), 0.0); }
vec3 shade_reflect(vec3 l, vec3 n) { return 2.0 * dot(n, l) * n - l; }
float shade_phong_specular(vec3 n, vec3 l, vec3 v, float shininess) {
    if (dot(n, l) <= 0.0) return 0.0;
    return pow(max(dot(shade_reflect(l, n), v), 0.0), shininess);
}
// I = ka·Ia + Il·(kd·max(0, n·l) + ks·spec); lit = false keeps the ambient term only (in shadow).
float shade_phong(vec4 k /* ka, kd, ks, shininess */, vec3 n, vec3 l, vec3 v, float ia, float il, bool lit) {
    float direct = lit ? il * (k.y * shade_lambert(n, l) + k.z * shade_phong_specular(n, l, v, k.w)) : 0.0;
    return shade_ambient(k.x, ia) + direct;
}
#endif
