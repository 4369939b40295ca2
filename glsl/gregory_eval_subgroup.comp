#version 460
// Uniform Gregory evaluation where the workgroup is one subgroup (subgroup barriers): see
// include/gregory_eval_body.glsl.
#define GREGORY_SUBGROUP_BARRIER 1
#include "gregory_eval_body.glsl"
