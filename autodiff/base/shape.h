// Shape of a tensor: rank 0 to 4, each extent >= 0.
//
// Construction checks the products: the element count (zero extents aside,
// so strides never overflow either) is at most kMaxElements, which keeps the
// byte count of any dtype within int64. A larger shape throws ShapeError
// naming it, so no tensor, stride or loop bound can wrap around.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace gr {

class Shape {
 public:
  static constexpr int kMaxRank = 4;
  // 2^60 - 1: times 8 bytes (float64) still fits in int64.
  static constexpr std::int64_t kMaxElements = INT64_MAX / 8;

  Shape() = default;  // rank 0: a scalar
  Shape(std::initializer_list<std::int64_t> dims);
  explicit Shape(const std::vector<std::int64_t>& dims);

  int rank() const { return rank_; }
  std::int64_t numel() const;
  // Extent of `axis`; negative axes count from the end (-1 is the last axis).
  std::int64_t operator[](int axis) const;
  // Normalizes a possibly negative axis to [0, rank); throws IndexError naming `what`.
  int normalize_axis(int axis, const std::string& what) const;
  std::vector<std::int64_t> dims() const { return {dims_.begin(), dims_.begin() + rank_}; }
  // Row-major strides in elements.
  std::array<std::int64_t, kMaxRank> strides() const;

  bool operator==(const Shape& o) const;
  bool operator!=(const Shape& o) const { return !(*this == o); }
  std::string str() const;  // "[2, 3]"

 private:
  void init(const std::int64_t* d, std::size_t n);
  std::array<std::int64_t, kMaxRank> dims_{};
  int rank_ = 0;
};

// a + b for extents (concat's sum along an axis); ShapeError naming `what` past kMaxElements.
std::int64_t add_extents(std::int64_t a, std::int64_t b, const std::string& what);
// a * b for extents or element counts (reshape's known extents); ShapeError naming `what` past kMaxElements.
std::int64_t multiply_extents(std::int64_t a, std::int64_t b, const std::string& what);

}  // namespace gr
