#include "ops/render/tensor_stamp.h"

namespace gr::detail {

TensorStamp TensorStamp::of(const Tensor& t) {
  if (!t.defined()) return {};
  return {true, t.impl()->storage, t.impl()->storage->version(), t.shape().dims(), t.dtype()};
}

bool TensorStamp::matches(const Tensor& t) const {
  if (!t.defined() || !defined) return !t.defined() && !defined;
  const std::shared_ptr<Storage> s = storage.lock();
  return s && s == t.impl()->storage && s->version() == version && dims == t.shape().dims() && dtype == t.dtype();
}

bool TensorStamp::stale() const {
  if (!defined) return false;
  const std::shared_ptr<Storage> s = storage.lock();
  return !s || s->version() != version;
}

}  // namespace gr::detail
