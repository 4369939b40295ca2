// One located query of the evaluation at (patch, u, v) (passes/patch_at.rs): the patch, its own (u, v) and
// the Jacobian J = d(u', v')/d(u, v) of the ptex-to-patch map. Mirrors gregvox::passes::patch_at::PatchQuery
// (#[repr(C)], u32, f32, f32, u32, [f32; 4]).
//
// patch_query_eval gathers the patch's 20 control points (f32 rows and their residuals) and evaluates
// gregory_eval_local in patch-local coordinates. It reads the buffers `points` and `patch_points` and
// `pc.residual_rows`, which the including shader declares before including this file.
#ifndef GREGVOX_PATCH_QUERY_GLSL
#define GREGVOX_PATCH_QUERY_GLSL
struct Query {
    uint patch_index;
    float u;
    float v;
    uint pad;
    vec4 jac;   // J00, J01, J10, J11
};

// The 20 control points of query x's patch relative to its first point (f32 rows first, then the
// residuals: exact differences for nearby points), and that first point as f32 row + residual.
void patch_query_points(Query x, out vec3 local[20], out vec3 hi0, out vec3 lo0) {
    uint base = 20u * x.patch_index;
    hi0 = points[patch_points[base]].xyz;
    lo0 = pc.residual_rows > 0u ? points[pc.residual_rows + patch_points[base]].xyz : vec3(0.0);
    for (int k = 0; k < 20; ++k) {
        uint r = patch_points[base + uint(k)];
        vec3 lo = pc.residual_rows > 0u ? points[pc.residual_rows + r].xyz : vec3(0.0);
        local[k] = (points[r].xyz - hi0) + (lo - lo0);
    }
}

// Position (world), patch-local first partials and the Bézier net of query x.
void patch_query_eval(Query x, out vec3 position, out vec3 su, out vec3 sv, out vec3 net[16]) {
    vec3 local[20], hi0, lo0;
    patch_query_points(x, local, hi0, lo0);
    vec3 p;
    gregory_eval_local(local, vec3(0.0), x.u, x.v, p, su, sv, net);
    position = (p + lo0) + hi0;
}
#endif
