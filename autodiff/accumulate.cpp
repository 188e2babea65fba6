#include "autodiff/accumulate.h"

#include "autodiff/parallel.h"

namespace gr {
namespace {

template <class T>
void add_arrays(T* out, const T* a, const T* b, std::int64_t n) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) out[i] = a[i] + b[i];
  });
}

}  // namespace

void accumulate_into(Tensor& dst, const Tensor& src) {
  if (!dst.defined()) {  // first contribution: adopt it (no copy)
    dst = src.detach();
    return;
  }
  // Shared storage (e.g. adopted from a tensor still alive elsewhere): write to a new buffer.
  const bool in_place = dst.impl_ptr().use_count() == 1 && dst.impl()->storage.use_count() == 1;
  Tensor out = in_place ? dst : Tensor::empty(dst.shape(), dst.dtype());
  dispatch_float(dst.dtype(), "gradient accumulation", [&](auto tag) {
    using T = decltype(tag);
    add_arrays(out.data<T>(), dst.data<T>(), src.data<T>(), dst.numel());
  });
  dst = out;
}

}  // namespace gr
