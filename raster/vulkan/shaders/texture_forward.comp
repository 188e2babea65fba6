#version 460
// 2D texture lookups (texture_forward.glsl over texture_taps.glsl).
#include "dispatch.glsl"
#include "texture_common.glsl"
#include "texture_taps.glsl"
#include "texture_forward.glsl"
