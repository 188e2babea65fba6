// Rendering one view of a vertex-coloured mesh with Lambert shading, every
// step a tensor op, so a loss on the image differentiates back to the vertex
// positions and colours. This is the part to copy into your own program.
#pragma once

#include "autodiff/tensor.h"

namespace fit {

using gr::Tensor;

// A camera and the light that travels with it.
struct Camera {
  Tensor view_projection;  // [4, 4]: clip = P V p
  Tensor light;            // [3]: unit direction towards the light, world space
};

struct Render {
  Tensor image;     // [H, W, 3] shaded colour, 0 on the background
  Tensor coverage;  // [H, W, 1] 1 where a triangle covers the pixel, else 0 (no gradient)
};

// albedo * (ambient + (1 - ambient) * max(n . l, 0)), per pixel.
Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light, double ambient = 0.2);

// positions [N, 3], colours [N, 3], triangles [M, 3] int32 -> a size x size image.
Render render(const Tensor& positions, const Tensor& colours, const Tensor& triangles, const Camera& camera,
              int size);

}  // namespace fit
