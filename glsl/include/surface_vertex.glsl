// One vertex of a surface vertex buffer, as the evaluation passes write it and the draw pipelines read it:
// position (w = 1) and unit normal (w = 0), stride 32 in std430. Mirrors gregvox::passes::gregory_eval::
// SurfaceVertex (#[repr(C)], [f32; 4] + [f32; 4]).
#ifndef GREGVOX_SURFACE_VERTEX_GLSL
#define GREGVOX_SURFACE_VERTEX_GLSL
struct Vertex { vec4 position; vec4 normal; };
#endif
