#version 460
// Cube-map lookups (texture_forward.glsl over cube_taps.glsl).
#include "dispatch.glsl"
#include "texture_common.glsl"
#include "cube_taps.glsl"
#include "texture_forward.glsl"
