// Dispatches larger than maxComputeWorkGroupCount[0] (65,535 on lavapipe) are split into 2D grids by
// gpu::pipeline::dispatch_grid; linear_invocation() rebuilds the linear index of a 1D workgroup.
// It is a macro, not a function, because gl_WorkGroupSize is only the shader's size after its
// `layout(local_size_x = …) in;` declaration: a function compiled above it would see (1,1,1).
#ifndef GREGVOX_DISPATCH_GLSL
#define GREGVOX_DISPATCH_GLSL
#define linear_invocation() \
    ((gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationIndex)
#endif
