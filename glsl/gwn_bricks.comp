#version 460
// Stage 1 of the generalized winding number (src/voxel/gwn.rs): one invocation per brick of 8³ voxels. A
// brick is listed (atomic append) unless every loop's ball lies farther than `near` and the bound
// Σ area / (4π d²) on |w_C| stays under ½ − margin: only listed bricks get their cap term evaluated.
// The loop over balls is at most 16,384 long (the engine checks; lavapipe cuts loops past 65,535).
#include "dispatch.glsl"
#include "gwn.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Balls { CapBall balls[]; };
layout(std430, set = 0, binding = 1) buffer Bricks { uint brick_count; uint bricks[]; };
layout(push_constant) uniform Push {
    dvec4 voxel_size;   // xyz: voxel size, w: near distance
    uvec4 dims;         // xyz: voxels per axis, w: balls
    uvec4 bdims;        // xyz: bricks per axis, w: bricks in all
} pc;

void main() {
    uint g = linear_invocation();
    if (g >= pc.bdims.w) return;
    uvec3 b = uvec3(g % pc.bdims.x, (g / pc.bdims.x) % pc.bdims.y, g / (pc.bdims.x * pc.bdims.y));
    dvec3 size = pc.voxel_size.xyz;
    double near = pc.voxel_size.w;
    dvec3 lo = gwn_centre(b * GWN_BRICK, size);
    dvec3 hi = gwn_centre(min(b * GWN_BRICK + GWN_BRICK, pc.dims.xyz) - 1u, size);
    precise double cx = (lo.x + hi.x) * 0.5lf;
    precise double cy = (lo.y + hi.y) * 0.5lf;
    precise double cz = (lo.z + hi.z) * 0.5lf;
    dvec3 c = dvec3(cx, cy, cz);
    precise double r = 0.5lf * gwn_norm(gwn_sub(hi, lo));
    precise double bound = 0.0lf;
    bool needed = false;
    for (uint l = 0u; l < pc.dims.w; ++l) {
        CapBall ball = balls[l];
        precise double d = gwn_norm(gwn_sub(c, ball.centre_radius.xyz)) - ball.centre_radius.w - r;
        if (d <= near) {
            needed = true;
            break;
        }
        precise double term = ball.area.x / (GWN_FOUR_PI * d * d);
        bound = bound + term;
        if (bound >= 0.5lf - GWN_MARGIN) {
            needed = true;
            break;
        }
    }
    if (needed) {
        uint slot = atomicAdd(brick_count, 1u);
        bricks[slot] = g;
    }
}
