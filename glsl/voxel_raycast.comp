#version 460
// Ray casts a bit-packed voxel grid (bit axis z: word (j*R + i)*W + k/32, bit k%32) into an RGBA8 storage
// image with the Amanatides-Woo 3D DDA on two levels (4^3 bricks from voxel_raycast_bricks.comp, then the
// voxels of occupied bricks); Lambert + ambient by the normal of the face the ray entered the hit
// voxel through. Mirrors src/voxel/raycast.rs operation for operation (same f32 order, `precise` against FMA
// contraction, same tie rules), so the CPU reference predicts every pixel except edge-grazing rays.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba8) uniform writeonly image2D out_image;
layout(std430, set = 0, binding = 1) readonly buffer Grid { uint bits[]; };
layout(std430, set = 0, binding = 3) readonly buffer Bricks { uint bricks[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Ids { uint ids[]; };   // (voxel id, rgba8) per pixel
layout(push_constant) uniform Push {
    vec4 eye;      // xyz eye (world), w 1/pitch
    vec4 forward;  // xyz unit view direction, w ambient
    vec4 right;    // xyz right * tan(fovy/2) * aspect, w background r
    vec4 up;       // xyz up * tan(fovy/2), w background g
    vec4 origin;   // xyz grid origin (world), w background b
    vec4 light;    // xyz unit direction to the light
    vec4 color;    // rgb voxel colour
    uvec4 params;  // x R, y width, z height, w 1 = write voxel ids
} pc;

const float MIN_DIR = 1e-12;
const uint MISS = 0xffffffffu;
const int BRICK = 4;

uint words_per_column() { return (pc.params.x + 31u) / 32u; }

bool solid(ivec3 c) {
    uint r = pc.params.x;
    uint w = (uint(c.y) * r + uint(c.x)) * words_per_column() + uint(c.z) / 32u;
    return ((bits[w] >> (uint(c.z) & 31u)) & 1u) == 1u;
}

float q8(float c) { return round(clamp(c, 0.0, 1.0) * 255.0) / 255.0; }

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    uint width = pc.params.y, height = pc.params.z;
    if (px.x >= width || px.y >= height) return;
    uint res = pc.params.x;
    precise float nx = (float(px.x) + 0.5) / float(width) * 2.0 - 1.0;
    precise float ny = (float(px.y) + 0.5) / float(height) * 2.0 - 1.0;
    precise vec3 dw = pc.forward.xyz + nx * pc.right.xyz - ny * pc.up.xyz;
    precise float len = sqrt(dw.x * dw.x + dw.y * dw.y + dw.z * dw.z);
    precise vec3 dir = dw / len;

    vec3 bg = vec3(pc.right.w, pc.up.w, pc.origin.w);
    vec4 result = vec4(q8(bg.r), q8(bg.g), q8(bg.b), 1.0);
    uint id = MISS;

    precise vec3 o = (pc.eye.xyz - pc.origin.xyz) * pc.eye.w;
    vec3 d;
    for (int a = 0; a < 3; ++a) {
        d[a] = abs(dir[a]) < MIN_DIR ? (dir[a] < 0.0 ? -MIN_DIR : MIN_DIR) : dir[a];
    }
    precise vec3 inv = 1.0 / d;
    float r = float(res);
    precise vec3 t0 = (vec3(0.0) - o) * inv;
    precise vec3 t1 = (vec3(r) - o) * inv;
    vec3 tmin = min(t0, t1);
    vec3 tmax = max(t0, t1);
    float t_enter = max(max(tmin.x, tmin.y), tmin.z);
    float t_exit = min(min(tmax.x, tmax.y), tmax.z);
    float t_start = max(t_enter, 0.0);
    if (t_exit >= t_start) {
        int axis = t_enter < 0.0 ? -1
                 : (tmin.x >= tmin.y && tmin.x >= tmin.z) ? 0
                 : (tmin.y >= tmin.z) ? 1 : 2;
        ivec3 stp = ivec3(d.x > 0.0 ? 1 : -1, d.y > 0.0 ? 1 : -1, d.z > 0.0 ? 1 : -1);
        ivec3 up = ivec3(stp.x > 0 ? 1 : 0, stp.y > 0 ? 1 : 0, stp.z > 0 ? 1 : 0);
        float bf = float(BRICK);
        int nb = (int(res) + BRICK - 1) / BRICK;
        vec3 t_delta = abs(inv);
        precise vec3 t_delta_b = bf * abs(inv);
        ivec3 brick;
        precise vec3 t_max_b;
        for (int a = 0; a < 3; ++a) {
            precise float p = o[a] + d[a] * t_start;
            brick[a] = clamp(int(floor(p / bf)), 0, nb - 1);
            t_max_b[a] = (float((brick[a] + up[a]) * BRICK) - o[a]) * inv[a];
        }
        int axis_b = axis;
        float t_in = t_start;
        bool done = false;
        for (int sb = 0; sb < 3 * nb + 3 && !done; ++sb) {
            if (bricks[(brick.z * nb + brick.y) * nb + brick.x] != 0u) {
                ivec3 lo = brick * BRICK;
                ivec3 hi = min(brick * BRICK + BRICK, ivec3(int(res)));
                ivec3 cell;
                precise vec3 t_max;
                for (int a = 0; a < 3; ++a) {
                    precise float p = o[a] + d[a] * t_in;
                    cell[a] = clamp(int(floor(p)), lo[a], hi[a] - 1);
                    t_max[a] = (float(cell[a] + up[a]) - o[a]) * inv[a];
                }
                int ax = axis_b;
                for (int s = 0; s < 3 * BRICK + 3; ++s) {
                    if (solid(cell)) {
                        vec3 n = vec3(0.0);
                        if (ax < 0) n = -d; else n[ax] = -float(stp[ax]);
                        precise float lambert = max(n.x * pc.light.x + n.y * pc.light.y + n.z * pc.light.z, 0.0);
                        float tint = ((cell.x + cell.y + cell.z) & 1) == 1 ? 0.9 : 1.0;
                        precise float f = (pc.forward.w + (1.0 - pc.forward.w) * lambert) * tint;
                        result = vec4(q8(pc.color.r * f), q8(pc.color.g * f), q8(pc.color.b * f), 1.0);
                        id = (uint(cell.z) * res + uint(cell.y)) * res + uint(cell.x);
                        done = true;
                        break;
                    }
                    int a = (t_max.x <= t_max.y && t_max.x <= t_max.z) ? 0 : (t_max.y <= t_max.z) ? 1 : 2;
                    cell[a] += stp[a];
                    if (cell[a] < lo[a] || cell[a] >= hi[a]) break;
                    t_max[a] += t_delta[a];
                    ax = a;
                }
                if (done) break;
            }
            int a = (t_max_b.x <= t_max_b.y && t_max_b.x <= t_max_b.z) ? 0 : (t_max_b.y <= t_max_b.z) ? 1 : 2;
            t_in = t_max_b[a];
            brick[a] += stp[a];
            if (brick[a] < 0 || brick[a] >= nb) break;
            t_max_b[a] += t_delta_b[a];
            axis_b = a;
        }
    }
    imageStore(out_image, ivec2(px), result);
    if (pc.params.w == 1u) {
        uint i = 2u * (px.y * width + px.x);
        ids[i] = id;
        ids[i + 1u] = packUnorm4x8(result);
    }
}
