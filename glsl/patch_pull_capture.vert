#version 460
// The vertex-pull path with capture of every evaluated vertex (tests). See include/patch_pull_body.glsl.
#define CAPTURE
#include "patch_pull_body.glsl"
