// Push constants of the surface draw pipelines (128 bytes: the guaranteed minimum).
layout(push_constant) uniform SurfacePush {
    mat4 view_proj;
    vec4 eye;        // xyz: camera position
    vec4 light;      // xyz: direction towards the light (unit), w: ambient intensity
    vec4 color;      // rgb: base colour
    uvec4 mode;      // x: shading mode (0 Phong, 1 normals, 2 zebra, 3 wireframe of patch boundaries,
                     //    4 mean curvature, 5 Gaussian curvature, 6 UV checker), y: level L,
                     // z: patch kind (vertex pull) or curvature scale (float bits, shadowed path),
                     // w: flags of the shadowed path (bit 0: ground plane, bit 1: shadows on,
                     //    bit 2: the UV stream holds the cage's UVs)
} pc;
