#version 460
// Adaptive Gregory evaluation (per-patch levels, snapped crack-free edges): see include/gregory_eval_body.glsl.
#define GREGORY_ADAPTIVE 1
#include "gregory_eval_body.glsl"
