// Shading building blocks (namespace gr::shading): sRGB transfer functions,
// BRDFs (Lambert, Blinn-Phong, GGX Cook-Torrance), lights (directional, point,
// cube-map environment), order-2 spherical-harmonics lighting, tangent frames
// and normal mapping. All are compositions of tensor ops, differentiable
// through the tape; gradraster.shading (Python) has the same functions.
// Conventions and formulas: docs/shading.md and the headers below.
#pragma once

#include "ops/shading/brdf.h"
#include "ops/shading/colour.h"
#include "ops/shading/lights.h"
#include "ops/shading/spherical_harmonics.h"
#include "ops/shading/tangent_frames.h"
