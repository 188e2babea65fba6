#include "autodiff/base/shape.h"

#include "autodiff/base/error.h"

namespace gr {
namespace {

std::string too_large(const std::string& what, const std::string& detail) {
  return what + ": " + detail + " exceeds the largest tensor of " +
         std::to_string(Shape::kMaxElements) + " elements (2^60 - 1)";
}

}  // namespace

std::int64_t add_extents(std::int64_t a, std::int64_t b, const std::string& what) {
  std::int64_t sum = 0;
  if (__builtin_add_overflow(a, b, &sum) || sum > Shape::kMaxElements)
    throw ShapeError(too_large(what, std::to_string(a) + " + " + std::to_string(b)));
  return sum;
}

std::int64_t multiply_extents(std::int64_t a, std::int64_t b, const std::string& what) {
  std::int64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product) || product > Shape::kMaxElements)
    throw ShapeError(too_large(what, std::to_string(a) + " * " + std::to_string(b)));
  return product;
}

Shape::Shape(std::initializer_list<std::int64_t> dims) { init(dims.begin(), dims.size()); }
Shape::Shape(const std::vector<std::int64_t>& dims) { init(dims.data(), dims.size()); }

void Shape::init(const std::int64_t* d, std::size_t n) {
  if (n > static_cast<std::size_t>(kMaxRank))
    throw ShapeError("shape: rank " + std::to_string(n) + " exceeds the maximum rank 4");
  rank_ = static_cast<int>(n);
  std::int64_t nonzero_product = 1;  // zero extents skipped: strides must not overflow either
  bool too_large = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (d[i] < 0) throw ShapeError("shape: negative extent " + std::to_string(d[i]));
    dims_[i] = d[i];
    if (d[i] != 0 && !too_large)
      too_large = __builtin_mul_overflow(nonzero_product, d[i], &nonzero_product) || nonzero_product > kMaxElements;
  }
  if (too_large)
    throw ShapeError("shape " + str() + ": the product of its extents exceeds the largest tensor of " +
                     std::to_string(kMaxElements) + " elements (2^60 - 1)");
}

std::int64_t Shape::numel() const {
  std::int64_t n = 1;
  for (int i = 0; i < rank_; ++i) n *= dims_[i];
  return n;
}

int Shape::normalize_axis(int axis, const std::string& what) const {
  int a = axis < 0 ? axis + rank_ : axis;
  if (a < 0 || a >= rank_)
    throw IndexError(what + ": axis " + std::to_string(axis) + " is out of range for shape " + str());
  return a;
}

std::int64_t Shape::operator[](int axis) const { return dims_[normalize_axis(axis, "shape")]; }

std::array<std::int64_t, Shape::kMaxRank> Shape::strides() const {
  std::array<std::int64_t, kMaxRank> s{};
  std::int64_t acc = 1;
  for (int i = rank_ - 1; i >= 0; --i) {
    s[i] = acc;
    acc *= dims_[i];
  }
  return s;
}

bool Shape::operator==(const Shape& o) const {
  if (rank_ != o.rank_) return false;
  for (int i = 0; i < rank_; ++i)
    if (dims_[i] != o.dims_[i]) return false;
  return true;
}

std::string Shape::str() const {
  std::string s = "[";
  for (int i = 0; i < rank_; ++i) {
    if (i) s += ", ";
    s += std::to_string(dims_[i]);
  }
  return s + "]";
}

}  // namespace gr
