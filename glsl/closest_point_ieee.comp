#version 460
// closest_point.comp for a driver whose f64 division is IEEE 754's (lavapipe: the CPU's own division), so
// its quotients need no correction; chosen by src/passes/closest_point.rs (`ieee_division`).
#define IEEE_DIVISION
#include "closest_point_body.glsl"
