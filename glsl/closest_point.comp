#version 460
// The nearest piece of the distance tree to each query point, in f64: one invocation per point walks the
// bounding-volume hierarchy of gregvox::mesh::distance::DistanceTree (laid out by
// `DistanceTree::device_layout`, bound by src/passes/closest_point.rs), nearer child first, never pushing a
// child farther than the best squared distance so far, and keeps the least (squared distance, triangle
// index): the CPU's answer and tie rule (`DistanceTree::closest_within_from`). It writes the slot of that
// piece, with the high bit set when the search stopped at its node limit; the host finishes those from
// the slot (the CPU search's starting hint), and with `verify` checks every answer that way.
//
// The closest point mirrors src/mesh/distance.rs (`closest_on_triangle`, `at`, `dot`) operation for
// operation, every intermediate `precise` (no fused multiply-add) and no built-in dot (its order is the
// driver's). Vulkan rounds f64 add, subtract and multiply correctly but not division, so each quotient is
// corrected to IEEE's from its exact remainder (`divide`): the squared distances are the CPU's bit for bit
// and so are the slots. closest_point_ieee.comp is this shader without the correction, for lavapipe, whose
// division is the CPU's. Needs shaderFloat64. The body is include/closest_point_body.glsl.
#include "closest_point_body.glsl"
