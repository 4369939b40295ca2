//! CPU mathematics with no Vulkan: Bézier, B-spline, NURBS, surfaces, the Gregory patch, curvature,
//! lecture kernels. The GPU paths are tested against these.
