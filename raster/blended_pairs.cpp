#include "raster/blended_pairs.h"

namespace gr::raster {

template <class T>
void blend_boundaries_forward(bool visibility, const AntialiasParams<T>& p, T* out, BlendedPairs* pairs,
                              const BlendStats& stats) {
  if (pairs) pairs->visibility = visibility;
  if (visibility)
    visibility_antialias_forward(p, out, pairs ? &pairs->boundary : nullptr, stats.boundary);
  else
    antialias_forward(p, out, pairs ? &pairs->silhouette : nullptr, stats.silhouette);
}

template <class T>
void blend_boundaries_backward(const AntialiasParams<T>& p, const BlendedPairs& pairs, const T* grad_out,
                               const AntialiasGrads<T>& grads) {
  if (pairs.visibility)
    visibility_antialias_backward(p, pairs.boundary, grad_out, grads);
  else
    antialias_backward(p, pairs.silhouette, grad_out, grads);
}

#define GR_INSTANTIATE(T)                                                                                  \
  template void blend_boundaries_forward<T>(bool, const AntialiasParams<T>&, T*, BlendedPairs*,            \
                                            const BlendStats&);                                            \
  template void blend_boundaries_backward<T>(const AntialiasParams<T>&, const BlendedPairs&, const T*,     \
                                             const AntialiasGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
