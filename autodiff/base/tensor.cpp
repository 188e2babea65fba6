#include "autodiff/base/tensor.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "autodiff/base/parallel.h"

namespace gr {
namespace {

// A double stored as int32: NaN, Inf and values outside the int32 range have no
// int32 (the conversion would be undefined behaviour), so they are refused.
std::int32_t to_int32(double v, const char* what, std::int64_t index) {
  if (!(v >= -2147483648.0 && v < 2147483648.0))
    throw ValueError(std::string(what) + ": value " + std::to_string(v) + (index >= 0 ? " at index " + std::to_string(index) : "") +
                     " is NaN, infinite or outside the int32 range");
  return static_cast<std::int32_t>(v);
}

// A tensor of uninitialized storage; filled: the caller writes it whole right
// away (its fresh pages are then mapped in one call, autodiff/base/storage.h).
std::shared_ptr<TensorImpl> new_impl(const Shape& shape, DType dtype, bool filled) {
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = shape;
  impl->dtype = dtype;
  try {
    // Cannot overflow: a Shape holds at most 2^60 - 1 elements (autodiff/base/shape.h).
    impl->storage = std::make_shared<Storage>(static_cast<std::size_t>(shape.numel()) * dtype_size(dtype), filled);
  } catch (const MemoryError& e) {
    throw MemoryError("tensor " + std::string(dtype_name(dtype)) + shape.str() + ": " + e.what());
  }
  return impl;
}

}  // namespace

Tensor Tensor::empty(const Shape& shape, DType dtype) { return Tensor(new_impl(shape, dtype, false)); }

Tensor Tensor::zeros(const Shape& shape, DType dtype) {
  Tensor t(new_impl(shape, dtype, true));
  // Large buffers (gradients of images) are cleared by all threads.
  constexpr std::int64_t kChunk = std::int64_t(1) << 20;  // bytes per task
  auto* bytes = static_cast<unsigned char*>(t.impl_->storage->data());
  const std::int64_t n = shape.numel() * static_cast<std::int64_t>(dtype_size(dtype));
  parallel_for(0, (n + kChunk - 1) / kChunk, 1, [&](std::int64_t c0, std::int64_t c1) {
    const std::int64_t lo = c0 * kChunk, hi = std::min(n, c1 * kChunk);
    std::memset(bytes + lo, 0, static_cast<std::size_t>(hi - lo));
  });
  return t;
}

Tensor Tensor::full(const Shape& shape, double value, DType dtype) {
  Tensor t(new_impl(shape, dtype, true));
  const std::int64_t n = shape.numel();
  switch (dtype) {
    case DType::Float32: { float* d = t.data<float>(); for (std::int64_t i = 0; i < n; ++i) d[i] = float(value); break; }
    case DType::Float64: { double* d = t.data<double>(); for (std::int64_t i = 0; i < n; ++i) d[i] = value; break; }
    case DType::Int32: {
      const std::int32_t v = to_int32(value, "Tensor::full", -1);
      std::int32_t* d = t.data<std::int32_t>();
      for (std::int64_t i = 0; i < n; ++i) d[i] = v;
      break;
    }
  }
  return t;
}

Tensor Tensor::ones(const Shape& shape, DType dtype) { return full(shape, 1.0, dtype); }
Tensor Tensor::scalar(double value, DType dtype) { return full(Shape{}, value, dtype); }

Tensor Tensor::from_values(const std::vector<double>& values, const Shape& shape, DType dtype) {
  if (static_cast<std::int64_t>(values.size()) != shape.numel())
    throw ShapeError("Tensor::from_values: " + std::to_string(values.size()) +
                     " values do not fill shape " + shape.str());
  Tensor t = empty(shape, dtype);
  for (std::size_t i = 0; i < values.size(); ++i) {
    switch (dtype) {
      case DType::Float32: t.data<float>()[i] = float(values[i]); break;
      case DType::Float64: t.data<double>()[i] = values[i]; break;
      case DType::Int32: t.data<std::int32_t>()[i] = to_int32(values[i], "Tensor::from_values", static_cast<std::int64_t>(i)); break;
    }
  }
  return t;
}

Tensor Tensor::uniform(const Shape& shape, double lo, double hi, std::uint64_t seed, DType dtype) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !std::isfinite(hi - lo) || lo > hi)
    throw ValueError("Tensor::uniform: the range [lo, hi) = [" + std::to_string(lo) + ", " + std::to_string(hi) +
                     ") must be finite with lo <= hi");
  Tensor t = empty(shape, dtype);
  std::mt19937_64 rng(seed);
  const std::int64_t n = shape.numel();
  for (std::int64_t i = 0; i < n; ++i) {
    // Map 53 random bits to [0, 1) ourselves: std::uniform_real_distribution's
    // output is implementation-defined, and results must not depend on the library.
    const double x = lo + (hi - lo) * (double(rng() >> 11) * 0x1.0p-53);
    switch (dtype) {
      case DType::Float32: t.data<float>()[i] = float(x); break;
      case DType::Float64: t.data<double>()[i] = x; break;
      case DType::Int32: t.data<std::int32_t>()[i] = to_int32(x, "Tensor::uniform", i); break;
    }
  }
  return t;
}

const TensorImpl& Tensor::checked() const {
  if (!impl_) throw ValueError("use of an undefined Tensor");
  return *impl_;
}

const Shape& Tensor::shape() const { return checked().shape; }
DType Tensor::dtype() const { return checked().dtype; }

void Tensor::check_dtype(DType expected) const {
  if (checked().dtype != expected)
    throw DTypeError(std::string("Tensor::data: tensor is ") + dtype_name(impl_->dtype) +
                     ", requested " + dtype_name(expected));
}

static double element_as_double(const TensorImpl& t, std::int64_t i) {
  switch (t.dtype) {
    case DType::Float32: return static_cast<const float*>(t.storage->data())[i];
    case DType::Float64: return static_cast<const double*>(t.storage->data())[i];
    case DType::Int32: return static_cast<const std::int32_t*>(t.storage->data())[i];
  }
  return 0;
}

double Tensor::item() const {
  if (numel() != 1) throw ShapeError("Tensor::item: tensor of shape " + shape().str() + " has " + std::to_string(numel()) + " elements, expected 1");
  return element_as_double(*impl_, 0);
}

double Tensor::at(std::initializer_list<std::int64_t> index) const {
  const Shape& s = shape();
  if (static_cast<int>(index.size()) != s.rank())
    throw IndexError("Tensor::at: " + std::to_string(index.size()) + " indices for a tensor of shape " + s.str());
  auto strides = s.strides();
  std::int64_t off = 0;
  int axis = 0;
  for (std::int64_t i : index) {
    if (i < 0 || i >= s[axis])
      throw IndexError("Tensor::at: index " + std::to_string(i) + " out of range on axis " + std::to_string(axis) + " of shape " + s.str());
    off += i * strides[axis++];
  }
  return element_as_double(*impl_, off);
}

std::vector<double> Tensor::to_vector() const {
  std::vector<double> v(static_cast<std::size_t>(numel()));
  for (std::int64_t i = 0; i < numel(); ++i) v[i] = element_as_double(*impl_, i);
  return v;
}

bool Tensor::requires_grad() const { return checked().requires_grad; }

Tensor& Tensor::set_requires_grad(bool on) {
  const TensorImpl& t = checked();
  if (t.recorded)
    throw TapeError("set_requires_grad: only leaf tensors can be marked; this one was produced by an op (use detach() first)");
  if (on && !is_floating(t.dtype))
    throw DTypeError(std::string("set_requires_grad: ") + dtype_name(t.dtype) + " tensors cannot require gradients");
  impl_->requires_grad = on;
  return *this;
}

bool Tensor::is_leaf() const { return !checked().recorded; }

Tensor Tensor::grad() const { return Tensor(checked().grad); }
bool Tensor::has_grad() const { return checked().grad != nullptr; }

void Tensor::zero_grad() { checked(); impl_->grad.reset(); }

Tensor Tensor::detach() const {
  const TensorImpl& t = checked();
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = t.shape;
  impl->dtype = t.dtype;
  impl->storage = t.storage;
  return Tensor(std::move(impl));
}

Tensor Tensor::copy() const {
  Tensor out = empty(shape(), dtype());
  std::memcpy(out.impl_->storage->data(), impl_->storage->data(), static_cast<std::size_t>(numel()) * dtype_size(dtype()));
  return out;
}

std::string Tensor::describe() const {
  if (!impl_) return "undefined";
  return std::string(dtype_name(impl_->dtype)) + impl_->shape.str();
}

}  // namespace gr
