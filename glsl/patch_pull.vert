#version 460
// See include/patch_pull_body.glsl.
#include "patch_pull_body.glsl"
