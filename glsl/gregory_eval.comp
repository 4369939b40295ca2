#version 460
// Uniform Gregory evaluation: see include/gregory_eval_body.glsl.
#include "gregory_eval_body.glsl"
