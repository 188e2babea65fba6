// A tensor as it was at one moment, to tell later whether a tensor is still
// it: the same storage (held weakly: the stamp keeps nothing alive), not
// written in place since (Storage::version), with the same shape and dtype.
// The device copies of ops/render/resident_gbuffer.h and resident_texture.h
// are read only while their tensors match their stamps.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::detail {

struct TensorStamp {
  bool defined = false;
  std::weak_ptr<Storage> storage;
  std::uint64_t version = 0;
  std::vector<std::int64_t> dims;
  DType dtype = DType::Float32;

  static TensorStamp of(const Tensor& t);
  // t is the stamped tensor, unwritten since (or both are undefined).
  bool matches(const Tensor& t) const;
  // The stamped storage is gone or written since: nothing matches any more.
  bool stale() const;
};

}  // namespace gr::detail
