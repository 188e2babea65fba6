// The book's C-style interface (ops/render/book_interface.h) against the tensor path
// it adapts: same G-buffer as rasterize, same colours as interpolate, and the
// gradients that backward gives on that path (itself gradchecked in float64).
#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

#include "autodiff/tape.h"
#include "ops/render/book_interface.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using book::FramePixel;
using book::GeometryPixel;
using book::Vertex;
using book::VertexGrad;

namespace {

constexpr int kWidth = 24, kHeight = 20;

// A tilted quad with a triangle in front of it (overlap, so the depth test matters).
const std::vector<Vertex> kVertices = {
    {{-0.9f, -0.7f, -0.2f}, {1.0f, 0.2f, 0.1f}}, {{0.8f, -0.8f, 0.1f}, {0.1f, 0.9f, 0.2f}},
    {{0.9f, 0.7f, -0.3f}, {0.2f, 0.3f, 1.0f}},   {{-0.7f, 0.8f, 0.0f}, {0.9f, 0.9f, 0.1f}},
    {{-0.3f, -0.4f, 0.5f}, {0.5f, 0.1f, 0.7f}},  {{0.5f, -0.1f, 0.4f}, {0.3f, 0.6f, 0.6f}},
    {{-0.1f, 0.5f, 0.6f}, {0.8f, 0.4f, 0.3f}}};
const std::vector<std::int32_t> kIndices = {0, 1, 2, 0, 2, 3, 4, 5, 6};
constexpr int kTriangles = 3;

// OpenGL perspective * look-at from (0.3, 0.2, 3), as the column-major float[16] the book passes.
std::vector<float> column_major_mvp() {
  const Tensor eye = Tensor::from_vector<float>({0.3f, 0.2f, 3.0f}, {3});
  const Tensor mvp = matmul(perspective(0.9, double(kWidth) / kHeight, 0.5, 10.0),
                            look_at(eye, Tensor::zeros({3}), Tensor::from_vector<float>({0, 1, 0}, {3})));
  std::vector<float> m(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * c + r] = static_cast<float>(mvp.at({r, c}));
  return m;
}

Tensor row_major(const std::vector<float>& column_major, DType dtype) {
  std::vector<double> rows(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) rows[4 * r + c] = column_major[4 * c + r];
  return Tensor::from_values(rows, {4, 4}, dtype);
}

Tensor vertex_field(DType dtype, bool position) {
  std::vector<double> v;
  for (const Vertex& x : kVertices)
    for (int c = 0; c < 3; ++c) v.push_back(position ? x.position[c] : x.color[c]);
  return Tensor::from_values(v, {static_cast<std::int64_t>(kVertices.size()), 3}, dtype);
}

const Tensor& triangles() {
  static const Tensor t = Tensor::from_vector(kIndices, {kTriangles, 3});
  return t;
}

struct BookFrame {
  std::vector<GeometryPixel> geometry{kWidth * kHeight};
  std::vector<FramePixel> frame{kWidth * kHeight};
};

BookFrame book_forward(const std::vector<float>& mvp) {
  BookFrame out;
  book::rasterizer_cpu_forward(kVertices.data(), int(kVertices.size()), kIndices.data(), kTriangles, mvp.data(),
                               kWidth, kHeight, out.geometry.data(), out.frame.data());
  return out;
}

// A fixed upstream gradient with every channel (alpha too) non-zero.
std::vector<FramePixel> upstream() {
  const Tensor g = Tensor::uniform({kHeight * kWidth, 4}, -1, 1, /*seed=*/7);
  std::vector<FramePixel> d(kWidth * kHeight);
  for (int p = 0; p < kWidth * kHeight; ++p)
    d[p] = {{float(g.at({p, 0})), float(g.at({p, 1})), float(g.at({p, 2}))}, float(g.at({p, 3}))};
  return d;
}

// The tensor path's colours, weighted by the upstream colour gradient.
Tensor tensor_path(const Tensor& positions, const Tensor& colors, const Tensor& mvp) {
  const Tensor clip = transform_points(positions, mvp);
  const GBuffer g = rasterize(clip, triangles(), {kWidth, kHeight});
  return interpolate(colors, g, triangles());
}

}  // namespace

TEST_CASE("book interface: rasterizer_cpu_forward writes rasterize's G-buffer and interpolate's colours", "[ops][book]") {
  const std::vector<float> mvp = column_major_mvp();
  const BookFrame book = book_forward(mvp);
  const Tensor clip = transform_points(vertex_field(DType::Float32, true), row_major(mvp, DType::Float32));
  const GBuffer g = rasterize(clip, triangles(), {kWidth, kHeight});
  const Tensor color = interpolate(vertex_field(DType::Float32, false), g, triangles());
  int covered = 0, front = 0;
  for (int j = 0; j < kHeight; ++j)
    for (int i = 0; i < kWidth; ++i) {
      const GeometryPixel& px = book.geometry[j * kWidth + i];
      const FramePixel& f = book.frame[j * kWidth + i];
      REQUIRE(px.tri_id == g.tri_id.at({j, i}));
      REQUIRE(px.u == float(g.uv.at({j, i, 0})));
      REQUIRE(px.v == float(g.uv.at({j, i, 1})));
      REQUIRE(px.depth == float(g.depth.at({j, i})));
      for (int c = 0; c < 3; ++c) REQUIRE(f.color[c] == float(color.at({j, i, c})));
      REQUIRE(f.alpha == (px.tri_id != 0 ? 1.0f : 0.0f));
      covered += px.tri_id != 0;
      front += px.tri_id == 3;
    }
  // The scene is not trivial: the quad and the triangle in front of it both show.
  CHECK(covered > 100);
  CHECK(front > 20);
  CHECK(covered < kWidth * kHeight);
}

TEST_CASE("book interface: the MVP is column-major, so a translation sits in entries 12 to 14", "[ops][book]") {
  std::vector<float> shift(16, 0.0f);
  shift[0] = shift[5] = shift[10] = shift[15] = 1.0f;
  shift[12] = 0.25f;  // x += 0.25 (column 3, row 0)
  const BookFrame book = book_forward(shift);
  Tensor moved = vertex_field(DType::Float32, true) + Tensor::from_vector<float>({0.25f, 0, 0}, {3});
  const GBuffer g = rasterize(to_homogeneous(moved), triangles(), {kWidth, kHeight});
  int covered = 0;
  for (int p = 0; p < kWidth * kHeight; ++p) {
    REQUIRE(book.geometry[p].tri_id == g.tri_id.at({p / kWidth, p % kWidth}));
    REQUIRE(book.geometry[p].u == float(g.uv.at({p / kWidth, p % kWidth, 0})));
    covered += book.geometry[p].tri_id != 0;
  }
  CHECK(covered > 0);
}

TEST_CASE("book interface: rasterizer_cpu_backward adds the tensor path's gradients, which pass gradcheck", "[ops][book][gradcheck]") {
  const std::vector<float> mvp = column_major_mvp();
  const BookFrame book = book_forward(mvp);
  const std::vector<FramePixel> d_frame = upstream();
  // vertex_grad starts at 0.5 everywhere: the book's backward adds to it.
  std::vector<VertexGrad> grad(kVertices.size());
  for (VertexGrad& g : grad)
    for (int c = 0; c < 3; ++c) g.d_position[c] = g.d_color[c] = 0.5f;
  book::rasterizer_cpu_backward(kVertices.data(), int(kVertices.size()), kIndices.data(), kTriangles, mvp.data(),
                                kWidth, kHeight, book.geometry.data(), d_frame.data(), grad.data());

  // The same path in float64, seeded with the same colour gradient.
  std::vector<double> up;
  for (const FramePixel& f : d_frame)
    for (int c = 0; c < 3; ++c) up.push_back(f.color[c]);
  const Tensor weights = Tensor::from_values(up, {kHeight, kWidth, 3}, DType::Float64);
  const Tensor mvp64 = row_major(mvp, DType::Float64);
  Tensor positions = vertex_field(DType::Float64, true).set_requires_grad();
  Tensor colors = vertex_field(DType::Float64, false).set_requires_grad();
  const auto f = [&](const std::vector<Tensor>& in) { return tensor_path(in[0], in[1], mvp64); };
  testing::require_gradcheck("book interface tensor path", f, {positions, colors}, {/*eps=*/1e-5});
  backward(f({positions, colors}), weights);
  double largest = 0;
  for (std::size_t k = 0; k < kVertices.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double dp = positions.grad().at({std::int64_t(k), c}), dc = colors.grad().at({std::int64_t(k), c});
      INFO("vertex " << k << " channel " << c);
      CHECK(grad[k].d_position[c] - 0.5 == Approx(dp).margin(1e-4).epsilon(1e-3));
      CHECK(grad[k].d_color[c] - 0.5 == Approx(dc).margin(1e-4).epsilon(1e-3));
      largest = std::max({largest, std::abs(dp), std::abs(dc)});
    }
  CHECK(largest > 0.1);  // the comparison is not between zeros
}

TEST_CASE("book interface: bad arguments throw ValueError naming them", "[ops][book]") {
  const std::vector<float> mvp = column_major_mvp();
  BookFrame book = book_forward(mvp);
  const std::vector<FramePixel> d_frame = upstream();
  std::vector<VertexGrad> grad(kVertices.size(), VertexGrad{});
  const auto backward_with = [&](const std::vector<GeometryPixel>& geometry) {
    book::rasterizer_cpu_backward(kVertices.data(), int(kVertices.size()), kIndices.data(), kTriangles, mvp.data(),
                                  kWidth, kHeight, geometry.data(), d_frame.data(), grad.data());
  };
  std::vector<GeometryPixel> other = book.geometry;
  for (GeometryPixel& px : other)
    if (px.tri_id != 0) {
      px.u += 0.01f;
      break;
    }
  CHECK_THROWS_WITH(backward_with(other), Catch::Contains("geometry differs"));
  CHECK_THROWS_AS(backward_with(other), ValueError);
  CHECK(Tape::current().size() == 0);  // the failed call left nothing recorded
  {
    Tensor pending = Tensor::ones({2}).set_requires_grad() * 2.0;
    CHECK_THROWS_AS(backward_with(book.geometry), TapeError);
    CHECK(Tape::current().size() == 1);  // the caller's graph is still there
    Tape::current().clear();
  }
  {
    NoGradGuard off;
    CHECK_THROWS_WITH(backward_with(book.geometry), Catch::Contains("NoGradGuard"));
  }
  CHECK_THROWS_WITH(book::rasterizer_cpu_forward(kVertices.data(), int(kVertices.size()), kIndices.data(), kTriangles,
                                                 nullptr, kWidth, kHeight, book.geometry.data(), book.frame.data()),
                    Catch::Contains("model_view_proj_4x4 is null"));
  CHECK_THROWS_WITH(book::rasterizer_cpu_forward(nullptr, 3, kIndices.data(), 1, mvp.data(), kWidth, kHeight,
                                                 book.geometry.data(), book.frame.data()),
                    Catch::Contains("vertices is null"));
  std::vector<float> bad = mvp;
  bad[5] = std::nanf("");
  CHECK_THROWS_WITH(book::rasterizer_cpu_forward(kVertices.data(), int(kVertices.size()), kIndices.data(), kTriangles,
                                                 bad.data(), kWidth, kHeight, book.geometry.data(), book.frame.data()),
                    Catch::Contains("model_view_proj_4x4 has a non-finite entry"));
}
