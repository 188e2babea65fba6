// The pixel pairs one antialiasing call blended, from either kernel:
// antialias (mesh silhouettes, raster/antialias.h) or visibility_antialias
// (every visibility boundary, intersection curves included,
// raster/visibility_antialias.h). The ops, the batched op and the Python
// binding run both kernels through these two calls.
#pragma once

#include <vector>

#include "raster/antialias.h"
#include "raster/visibility_antialias.h"

namespace gr::raster {

struct BlendedPairs {
  bool visibility = false;                 // which kernel blended them
  std::vector<AntialiasPair> silhouette;   // antialias's
  std::vector<VisibilityPair> boundary;    // visibility_antialias's
};

// Either kernel's pair counts (the one that runs fills its own, if set).
struct BlendStats {
  AntialiasStats* silhouette = nullptr;
  VisibilityAntialiasStats* boundary = nullptr;
};

// visibility ? visibility_antialias_forward : antialias_forward, the pairs
// (if non-null) recorded with the kernel that made them.
template <class T>
void blend_boundaries_forward(bool visibility, const AntialiasParams<T>& p, T* out, BlendedPairs* pairs = nullptr,
                              const BlendStats& stats = {});

// The adjoint of the kernel that blended `pairs`, accumulated into grads.
template <class T>
void blend_boundaries_backward(const AntialiasParams<T>& p, const BlendedPairs& pairs, const T* grad_out,
                               const AntialiasGrads<T>& grads);

}  // namespace gr::raster
