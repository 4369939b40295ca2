#version 460
// A-buffer scatter: every fragment of the mesh goes to its column's slice of the fragment buffer,
// slot offsets[col] + atomicAdd(cursor[col], 1), as signed depth ±(z + 1) (+ front-facing). Unlike peeling,
// two fragments at the same depth both land: nothing is lost. The slice length is the count pre-pass's
// count for the column (same vertex shader, `invariant gl_Position`, same raster state), so the guard below
// never triggers; it only keeps a broken invariant from writing into a neighbour's slice.
#include "peel_common.glsl"
layout(std430, set = 0, binding = 0) readonly buffer Offsets { uint offsets[]; };
layout(std430, set = 0, binding = 1) buffer Cursor { uint cursor[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Frags { float frags[]; };
void main() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    uint col = p.y * pc.extent.x + p.x;
    uint slot = atomicAdd(cursor[col], 1u);
    uint begin = offsets[col];
    if (slot < offsets[col + 1u] - begin) {
        frags[begin + slot] = gl_FrontFacing ? gl_FragCoord.z + 1.0 : -(gl_FragCoord.z + 1.0);
    }
}
