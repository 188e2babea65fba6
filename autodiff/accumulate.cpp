#include "autodiff/accumulate.h"

#include <array>
#include <functional>
#include <mutex>

#include "autodiff/base/parallel.h"

namespace gr {
namespace {

template <class T>
void add_arrays(T* out, const T* a, const T* b, std::int64_t n) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) out[i] = a[i] + b[i];
  });
}

// The stripe that guards a leaf's grad pointer.
std::mutex& leaf_stripe(const TensorImpl& leaf) {
  static std::array<std::mutex, 64> stripes;
  return stripes[std::hash<const TensorImpl*>()(&leaf) / alignof(TensorImpl) % stripes.size()];
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

void accumulate_leaf_grad(TensorImpl& leaf, const Tensor& grad) {
  // Striped locks: a leaf's stripe guards its grad pointer. The sum itself runs
  // outside the lock (it may use parallel_for, whose waiting thread can pick up
  // another thread's task): take the leaf's gradient out, add, and put the sum
  // back if the slot is still empty; if another thread put its own sum there
  // meanwhile, take that out too and add again.
  Tensor sum = grad.detach();
  std::unique_lock<std::mutex> lock(leaf_stripe(leaf));
  while (leaf.grad) {
    Tensor g(std::move(leaf.grad));
    lock.unlock();
    accumulate_into(g, sum);
    sum = g;
    lock.lock();
  }
  leaf.grad = sum.impl_ptr();
}

void ensure_leaf_grad(TensorImpl& leaf, const Shape& shape, DType dtype) {
  // A slot another thread has taken out (see above) looks empty here; the zeros
  // put there are then added into that thread's sum, which changes nothing.
  std::lock_guard<std::mutex> lock(leaf_stripe(leaf));
  if (!leaf.grad) leaf.grad = Tensor::zeros(shape, dtype).impl_ptr();
}

}  // namespace gr
