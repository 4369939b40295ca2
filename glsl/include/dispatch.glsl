// Dispatches larger than maxComputeWorkGroupCount[0] (65,535 on lavapipe) are split into 2D grids by
// gpu::pipeline::dispatch_grid; this rebuilds the linear invocation index. The host passes the group count
// of a full row in gl_NumWorkGroups.x.
#ifndef GREGVOX_DISPATCH_GLSL
#define GREGVOX_DISPATCH_GLSL
uint linear_invocation() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    return group * gl_WorkGroupSize.x + gl_LocalInvocationIndex;
}
#endif
