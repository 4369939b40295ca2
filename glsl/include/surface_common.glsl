// Push constants of the surface draw pipeline (128 bytes: the guaranteed minimum).
layout(push_constant) uniform SurfacePush {
    mat4 view_proj;
    vec4 eye;        // xyz: camera position
    vec4 light;      // xyz: direction towards the light (unit), w: ambient intensity
    vec4 color;      // rgb: base colour
    uvec4 mode;      // x: shading mode (0 Phong, 1 normals, 2 zebra, 3 patch grid), y: level L
} pc;
