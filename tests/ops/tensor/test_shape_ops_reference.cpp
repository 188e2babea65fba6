// slice, concat and stack against naive index loops (one multi-index per
// element, divisions and all) on random shapes, empty and one-channel ones
// included, forward and adjoint, every dtype; and the channel moves of the fit
// ([H, W, 4] <-> [H, W, 3] + [H, W, 1]) bit-identical for any thread count.
#include <catch2/catch.hpp>

#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::same_bits;

namespace {

using Dims = std::vector<std::int64_t>;

std::int64_t numel(const Dims& d) {
  std::int64_t n = 1;
  for (std::int64_t x : d) n *= x;
  return n;
}

// Multi-index of flat index `flat` in row-major `dims`.
Dims unravel(std::int64_t flat, const Dims& dims) {
  Dims idx(dims.size());
  for (std::size_t k = dims.size(); k-- > 0;) {
    idx[k] = flat % dims[k];
    flat /= dims[k];
  }
  return idx;
}

std::int64_t ravel(const Dims& idx, const Dims& dims) {
  std::int64_t flat = 0;
  for (std::size_t k = 0; k < dims.size(); ++k) flat = flat * dims[k] + idx[k];
  return flat;
}

// The indices Python's range(*slice(start, stop, step).indices(n)) visits.
std::vector<std::int64_t> python_slice(std::int64_t n, std::int64_t start, std::int64_t stop, std::int64_t step) {
  auto adjust = [&](std::int64_t v) {
    if (v < 0) {
      v += n;
      if (v < 0) v = step < 0 ? -1 : 0;
    } else if (v >= n) {
      v = step < 0 ? n - 1 : n;
    }
    return v;
  };
  std::vector<std::int64_t> picked;
  for (std::int64_t i = adjust(start); step > 0 ? i < adjust(stop) : i > adjust(stop); i += step) picked.push_back(i);
  return picked;
}

// Values 1, 2, 3, ... (exact in every dtype) of the given shape.
Tensor counting(const Dims& d, DType dtype) {
  std::vector<double> v(static_cast<std::size_t>(numel(d)));
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = double(i + 1);
  return Tensor::from_values(v, Shape(d), dtype);
}

Dims random_dims(std::mt19937& rng, int rank, std::int64_t max_extent) {
  Dims d(static_cast<std::size_t>(rank));
  for (std::int64_t& x : d) x = std::uniform_int_distribution<std::int64_t>(0, max_extent)(rng);
  return d;
}

const DType kDTypes[] = {DType::Float32, DType::Float64, DType::Int32};

// Checks slice(a, axis, start, stop, step) of a counting tensor against the
// index loop, and for float dtypes its gradient from a random g.
void check_slice(const Dims& dims, int axis, std::int64_t start, std::int64_t stop, std::int64_t step, DType dtype,
                 std::uint64_t seed) {
  INFO("shape " << Shape(dims).str() << " axis " << axis << " slice " << start << ":" << stop << ":" << step << " "
                << dtype_name(dtype));
  const std::vector<std::int64_t> picked = python_slice(dims[axis], start, stop, step);
  Dims out_dims = dims;
  out_dims[axis] = std::int64_t(picked.size());
  // Input index of every output element.
  std::vector<std::int64_t> source(static_cast<std::size_t>(numel(out_dims)));
  for (std::int64_t o = 0; o < numel(out_dims); ++o) {
    Dims idx = unravel(o, out_dims);
    idx[axis] = picked[idx[axis]];
    source[o] = ravel(idx, dims);
  }

  Tensor a = counting(dims, dtype);
  if (dtype != DType::Int32) a.set_requires_grad();
  const Tensor out = slice(a, axis, start, stop, step);
  REQUIRE(out.shape() == Shape(out_dims));
  const std::vector<double> av = a.to_vector(), ov = out.to_vector();
  std::vector<double> expected(source.size());
  for (std::size_t o = 0; o < source.size(); ++o) expected[o] = av[source[o]];
  CHECK(ov == expected);

  if (dtype == DType::Int32) return;
  const Tensor g = Tensor::uniform(Shape(out_dims), -1, 1, seed, dtype);
  backward(out, g);
  std::vector<double> ga(av.size(), 0.0);
  const std::vector<double> gv = g.to_vector();
  for (std::size_t o = 0; o < source.size(); ++o) ga[source[o]] += gv[o];
  CHECK(a.grad().to_vector() == ga);
}

}  // namespace

TEST_CASE("slice: on random shapes, steps and bounds it picks what a naive index loop picks, and its gradient "
          "puts g back there with zeros elsewhere",
          "[ops][shape]") {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    const int rank = 1 + trial % 4;
    Dims dims = random_dims(rng, rank, trial % 3 == 0 ? 2 : 6);
    const int axis = std::uniform_int_distribution<int>(0, rank - 1)(rng);
    if (trial % 5 == 0) dims.back() = 1 + trial % 4;  // image channels, one-channel images
    const std::int64_t n = dims[axis];
    auto bound = [&] { return std::uniform_int_distribution<std::int64_t>(-n - 2, n + 2)(rng); };
    const std::int64_t start = bound(), stop = bound();
    std::int64_t step = std::uniform_int_distribution<std::int64_t>(-3, 3)(rng);
    if (step == 0 || trial % 2 == 0) step = 1;  // step 1 is the fast path: test it most
    INFO("trial " << trial);
    check_slice(dims, axis, start, stop, step, kDTypes[trial % 3], 100 + trial);
  }
}

TEST_CASE("concat and stack: on random shapes with empty and one-channel parts they join like a naive index "
          "loop, and their gradients hand each part its piece of g",
          "[ops][shape]") {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 200; ++trial) {
    const bool stacking = trial % 4 == 3;
    const int rank = stacking ? 1 + trial % 3 : 1 + trial % 4;
    const Dims base = random_dims(rng, rank, trial % 3 == 0 ? 2 : 5);
    const int axis = std::uniform_int_distribution<int>(0, stacking ? rank : rank - 1)(rng);
    const int count = std::uniform_int_distribution<int>(1, 4)(rng);
    const DType dtype = kDTypes[trial % 3];
    // Parts: for concat the extent along axis varies (0..6, channels 1..4 among them).
    std::vector<Dims> part_dims;
    std::vector<Tensor> parts;
    for (int i = 0; i < count; ++i) {
      Dims d = base;
      if (!stacking) d[axis] = std::uniform_int_distribution<std::int64_t>(0, 6)(rng);
      part_dims.push_back(d);
      Tensor t = counting(d, dtype);
      if (dtype != DType::Int32) t.set_requires_grad();
      parts.push_back(t);
    }
    INFO("trial " << trial << (stacking ? ": stack of " : ": concat of ") << count << " parts like "
                  << Shape(part_dims[0]).str() << " along axis " << axis);
    const Tensor out = stacking ? stack(parts, axis) : concat(parts, axis);

    // Reference: the output multi-index names the part and its element.
    Dims out_dims = base;
    if (stacking) {
      out_dims.insert(out_dims.begin() + axis, count);
    } else {
      out_dims[axis] = 0;
      for (const Dims& d : part_dims) out_dims[axis] += d[axis];
    }
    REQUIRE(out.shape() == Shape(out_dims));
    std::vector<std::pair<int, std::int64_t>> source(static_cast<std::size_t>(numel(out_dims)));
    for (std::int64_t o = 0; o < numel(out_dims); ++o) {
      Dims idx = unravel(o, out_dims);
      int part = 0;
      if (stacking) {
        part = int(idx[axis]);
        idx.erase(idx.begin() + axis);
      } else {
        while (idx[axis] >= part_dims[part][axis]) idx[axis] -= part_dims[part++][axis];
      }
      source[o] = {part, ravel(idx, part_dims[part])};
    }
    std::vector<std::vector<double>> values;
    for (const Tensor& t : parts) values.push_back(t.to_vector());
    std::vector<double> expected(source.size());
    for (std::size_t o = 0; o < source.size(); ++o) expected[o] = values[source[o].first][source[o].second];
    CHECK(out.to_vector() == expected);

    if (dtype == DType::Int32) continue;
    const Tensor g = Tensor::uniform(Shape(out_dims), -1, 1, 200 + trial, dtype);
    backward(out, g);
    const std::vector<double> gv = g.to_vector();
    std::vector<std::vector<double>> grads;
    for (const Tensor& t : parts) grads.emplace_back(static_cast<std::size_t>(t.numel()), 0.0);
    for (std::size_t o = 0; o < source.size(); ++o) grads[source[o].first][source[o].second] = gv[o];
    for (int i = 0; i < count; ++i) CHECK(parts[i].grad().to_vector() == grads[i]);
  }
}

TEST_CASE("slice and concat of image channels: the fit's rgba moves are bit-identical for 1, 2 and 8 threads",
          "[ops][shape][determinism]") {
  // 96 x 300 pixels: well above one parallel chunk, so several threads split the rows.
  auto run = [](int threads) {
    set_num_threads(threads);
    const Tensor rgb = Tensor::uniform({96, 300, 3}, -1, 1, 1).set_requires_grad();
    const Tensor alpha = Tensor::uniform({96, 300, 1}, -1, 1, 2).set_requires_grad();
    const Tensor rgba = concat({rgb, alpha}, 2);
    const Tensor back_rgb = slice(rgba, 2, 0, 3), back_alpha = slice(rgba, 2, 3, 4);
    const Tensor odd = slice(rgba, 2, -1, -5, -2);  // channels 3 and 1: the stepped path
    backward(sum(back_rgb * back_rgb) + sum(3.0 * back_alpha) + sum(odd * odd * odd));
    set_num_threads(0);
    return std::vector<Tensor>{rgba, back_rgb, back_alpha, odd, rgb.grad(), alpha.grad()};
  };
  const std::vector<Tensor> one = run(1);
  for (int threads : {2, 8}) {
    const std::vector<Tensor> many = run(threads);
    for (std::size_t k = 0; k < one.size(); ++k) {
      INFO(threads << " threads, result " << k);
      CHECK(same_bits(one[k], many[k]));
    }
  }
}

TEST_CASE("slice: long slices split over rows (axis 0) or over blocks with more rows than blocks match the "
          "index loop, gradient too, for 1, 2 and 8 threads",
          "[ops][shape][determinism]") {
  for (int threads : {1, 2, 8}) {
    INFO(threads << " threads");
    set_num_threads(threads);
    check_slice({40000, 2}, 0, 7, -5, 1, DType::Float32, 11);   // one block of 39988 rows
    check_slice({40000, 2}, 0, -2, 3, -3, DType::Float64, 12);  // stepped backwards
    check_slice({80, 2000}, 1, 5, 1990, 1, DType::Float32, 13);  // 80 blocks of 1985 rows
    check_slice({80, 2000}, 1, 1999, 0, -7, DType::Float32, 14);
    set_num_threads(0);
  }
}
