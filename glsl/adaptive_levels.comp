#version 460
// Screen-space adaptive tessellation levels (src/passes/adaptive_levels.rs). Two modes, one dispatch each:
// mode 0, one invocation per patch: L_p = clamp(ceil(s / pixels_per_segment), 1, L_max) where s is the
// longest of the patch's four projected boundary control polygons in pixels (3 segments each); a patch with
// a control point at or behind the eye plane (clip w ≤ 1e-6·|clip|) gets L_max, since its projected size is
// unbounded. Writes levels[p] and the patch's VkDrawIndexedIndirectCommand: indexCount 6·L_p², one instance,
// firstIndex = Σ_{l<L_p} 6·l² (the grids of all levels concatenated), vertexOffset = p·(L_max+1)².
// mode 1, one invocation per shared edge: L_e = min of L_p over the patches listed for the edge (CSR
// edge_offsets / edge_patches), so both sides of an edge snap to the same, coarser, samples.
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, set = 0, binding = 1) readonly buffer PatchPoints { uint patch_points[]; };
layout(std430, set = 0, binding = 2) buffer Levels { uint levels[]; };
struct DrawCommand { uint index_count; uint instance_count; uint first_index; int vertex_offset; uint first_instance; };
layout(std430, set = 0, binding = 3) writeonly buffer Commands { DrawCommand commands[]; };
layout(std430, set = 0, binding = 4) readonly buffer EdgeOffsets { uint edge_offsets[]; };
layout(std430, set = 0, binding = 5) readonly buffer EdgePatches { uint edge_patches[]; };
layout(std430, set = 0, binding = 6) writeonly buffer EdgeLevels { uint edge_levels[]; };
layout(push_constant) uniform Push {
    mat4 view_proj;
    vec2 viewport;          // pixels
    float pixels_per_segment;
    uint l_max;
    uint count;             // patches (mode 0) or edges (mode 1)
    uint mode;
} pc;

// Boundary control polygon of each edge (GREGORY_BASIS indices), in parameter order.
const uint EDGE_POINTS[16] = uint[16](0, 1, 7, 5,  5, 6, 12, 10,  15, 17, 11, 10,  0, 2, 16, 15);

void main() {
    uint id = gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * gl_WorkGroupSize.x) + gl_GlobalInvocationID.x;
    if (id >= pc.count) return;
    if (pc.mode == 1u) {
        uint level = pc.l_max;
        for (uint k = edge_offsets[id]; k < edge_offsets[id + 1u]; ++k) {
            level = min(level, levels[edge_patches[k]]);
        }
        edge_levels[id] = level;
        return;
    }
    // Longest projected boundary control polygon, in pixels. NDC [-1, 1] spans the viewport.
    float longest = 0.0;
    bool behind = false;
    for (uint e = 0u; e < 4u; ++e) {
        float len = 0.0;
        vec2 prev = vec2(0.0);
        for (uint k = 0u; k < 4u; ++k) {
            vec3 p = points[patch_points[20u * id + EDGE_POINTS[4u * e + k]]].xyz;
            vec4 c = pc.view_proj * vec4(p, 1.0);
            behind = behind || !(c.w > 1e-6 * length(c.xyz));
            vec2 s = (c.xy / c.w) * (0.5 * pc.viewport);
            if (k > 0u) len += distance(prev, s);
            prev = s;
        }
        longest = max(longest, len);
    }
    float want = ceil(longest / pc.pixels_per_segment);
    // NaN or huge sizes (and points behind the eye) take L_max.
    uint level = (behind || !(want < float(pc.l_max))) ? pc.l_max : max(uint(want), 1u);
    levels[id] = level;
    commands[id].index_count = 6u * level * level;
    commands[id].instance_count = 1u;
    // Σ_{l<L} 6·l² = (L−1)·L·(2L−1).
    commands[id].first_index = (level - 1u) * level * (2u * level - 1u);
    commands[id].vertex_offset = int(id * (pc.l_max + 1u) * (pc.l_max + 1u));
    commands[id].first_instance = 0u;
}
