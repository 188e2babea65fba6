// Tensor: a shaped, contiguous, row-major array of float32, float64 or int32
// values that can take part in reverse-mode differentiation.
//
// A Tensor is a cheap handle (shared ownership of its storage). Operations on
// tensors live in ops/; each records itself on the thread's gradient tape
// (autodiff/tape.h) when one of its inputs requires a gradient.
//
//   Tensor x = Tensor::from_vector<double>({1, 2, 3}, {3}).set_requires_grad();
//   Tensor loss = sum(x * x);
//   backward(loss);          // x.grad() == [2, 4, 6]
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "autodiff/base/dtype.h"
#include "autodiff/base/shape.h"
#include "autodiff/base/storage.h"

namespace gr {

struct TensorImpl {
  Shape shape;
  DType dtype = DType::Float32;
  std::shared_ptr<Storage> storage;
  bool requires_grad = false;
  // Produced by a recorded op (false for user-created tensors: leaves).
  bool recorded = false;
  // For recorded tensors: which tape (Tape::id), generation and gradient slot they belong to.
  std::uint64_t tape_id = 0;
  std::uint64_t tape_generation = 0;
  std::int64_t grad_slot = -1;
  // Accumulated gradient of a leaf that requires grad (written under
  // accumulate_leaf_grad's lock; read it when no backward() is running).
  std::shared_ptr<TensorImpl> grad;
};

class Tensor {
 public:
  Tensor() = default;  // an undefined tensor (defined() == false)
  explicit Tensor(std::shared_ptr<TensorImpl> impl) : impl_(std::move(impl)) {}

  // Factories. Contents of empty() are unspecified. Every factory's storage counts
  // against the memory budget (autodiff/base/memory.h): MemoryError names the dtype and
  // shape of a request past the limit. Values stored as int32 must be finite and in
  // the int32 range (ValueError otherwise).
  static Tensor empty(const Shape& shape, DType dtype = DType::Float32);
  static Tensor zeros(const Shape& shape, DType dtype = DType::Float32);
  static Tensor ones(const Shape& shape, DType dtype = DType::Float32);
  static Tensor full(const Shape& shape, double value, DType dtype = DType::Float32);
  static Tensor scalar(double value, DType dtype = DType::Float32);
  // Copies `values` (converted to `dtype`); values.size() must equal shape.numel().
  static Tensor from_values(const std::vector<double>& values, const Shape& shape,
                            DType dtype = DType::Float32);
  template <class T>
  static Tensor from_vector(const std::vector<T>& values, const Shape& shape);
  // Uniform random values in [lo, hi) from a fixed-seed generator (reproducible).
  // lo and hi must be finite with lo <= hi (ValueError otherwise).
  static Tensor uniform(const Shape& shape, double lo, double hi, std::uint64_t seed,
                        DType dtype = DType::Float32);

  bool defined() const { return impl_ != nullptr; }
  const Shape& shape() const;
  int rank() const { return shape().rank(); }
  std::int64_t numel() const { return shape().numel(); }
  std::int64_t size(int axis) const { return shape()[axis]; }
  DType dtype() const;

  // Typed access to the contiguous elements; throws DTypeError if T does not match.
  // The non-const overload is the in-place write path: each call counts as a
  // write into the storage (shared with detach()ed handles), so taking it on a
  // tensor the tape recorded, between the forward computation and backward(),
  // makes backward() throw TapeError (autodiff/tape.h). Write into a copy()
  // instead, or after backward(); to only read, use the const overload
  // (std::as_const(t).data<T>(), or a const Tensor&).
  template <class T> T* data();
  template <class T> const T* data() const;
  // The single element of a one-element tensor, converted to double.
  double item() const;
  // Element at a multi-index (slow; for tests and small tensors), converted to double.
  double at(std::initializer_list<std::int64_t> index) const;
  // All elements converted to double, in row-major order.
  std::vector<double> to_vector() const;

  // Gradient tracking.
  bool requires_grad() const;
  // Marks a leaf as a parameter whose gradient backward() accumulates.
  Tensor& set_requires_grad(bool on = true);
  // True if the tensor was not produced by a recorded op.
  bool is_leaf() const;
  // Accumulated gradient of a leaf that requires grad. Undefined (has_grad()
  // false) until a backward() whose loss depends on the leaf through recorded
  // ops; from then on defined, with zeros wherever the derivative is zero (an
  // uncovered pixel, a clamped value, a nearest-filter texture's uv), the same
  // for every op. Each backward() adds to it; zero_grad() makes it undefined
  // again. A leaf the loss does not depend on (unused, or used only under
  // NoGradGuard or in a comparison mask) keeps an undefined grad.
  Tensor grad() const;
  bool has_grad() const;
  void zero_grad();
  // Same storage, cut from the tape: no gradient flows through the result.
  Tensor detach() const;
  // A new tensor with its own copy of the storage, not recorded on the tape.
  Tensor copy() const;

  // True if both handles refer to the same tensor.
  bool same(const Tensor& other) const { return impl_ == other.impl_; }
  std::string describe() const;  // e.g. "float32[4, 3]"
  TensorImpl* impl() const { return impl_.get(); }
  const std::shared_ptr<TensorImpl>& impl_ptr() const { return impl_; }

 private:
  const TensorImpl& checked() const;
  void check_dtype(DType expected) const;
  std::shared_ptr<TensorImpl> impl_;
};

template <class T>
T* Tensor::data() {
  check_dtype(dtype_of<T>::value);
  impl_->storage->bump_version();
  return static_cast<T*>(impl_->storage->data());
}

template <class T>
const T* Tensor::data() const {
  check_dtype(dtype_of<T>::value);
  return static_cast<const T*>(impl_->storage->data());
}

template <class T>
Tensor Tensor::from_vector(const std::vector<T>& values, const Shape& shape) {
  if (static_cast<std::int64_t>(values.size()) != shape.numel())
    throw ShapeError("Tensor::from_vector: " + std::to_string(values.size()) +
                     " values do not fill shape " + shape.str());
  Tensor t = empty(shape, dtype_of<T>::value);
  T* d = t.data<T>();
  for (std::size_t i = 0; i < values.size(); ++i) d[i] = values[i];
  return t;
}

}  // namespace gr
