// The whole differentiable chain in one gradient check: model-space vertices,
// vertex colours and camera parameters -> MVP -> rasterize -> perspective-
// correct interpolation -> Lambert shading -> image.
#include <catch2/catch.hpp>

#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

struct Scene {
  Tensor positions, colours, normals, eye, fov, triangles;
};

Scene make_scene() {
  raster::Mesh mesh = raster::make_icosphere(1, 0.8f);
  Scene s;
  s.positions = cast(mesh.positions, DType::Float64).set_requires_grad();
  s.normals = cast(mesh.normals, DType::Float64);
  s.colours = Tensor::uniform({mesh.num_vertices(), 3}, 0.1, 0.9, 51, DType::Float64).set_requires_grad();
  s.eye = Tensor::from_values({0.3, 0.4, 2.6}, {3}, DType::Float64).set_requires_grad();
  s.fov = Tensor::scalar(0.9, DType::Float64).set_requires_grad();
  s.triangles = mesh.triangles;
  return s;
}

// A rendered image [H, W, 3] plus 0.1 * depth, so every adjoint on the path is used.
Tensor render(const Tensor& positions, const Tensor& colours, const Tensor& normals, const Tensor& eye,
              const Tensor& fov, const Tensor& triangles) {
  const int w = 28, h = 24;
  Tensor target = Tensor::zeros({3}, DType::Float64);
  Tensor up = Tensor::from_values({0, 1, 0}, {3}, DType::Float64);
  Tensor mvp = matmul(perspective(fov, double(w) / h, 0.5, 10.0), look_at(eye, target, up));
  Tensor clip = transform_points(positions, mvp);
  GBuffer gb = rasterize(clip, triangles, {w, h});
  Tensor albedo = interpolate(colours, gb, triangles);
  Tensor n = normalize(interpolate(normals, gb, triangles));
  Tensor light = normalize(Tensor::from_values({0.5, 0.8, 1.0}, {3}, DType::Float64));
  Tensor shaded = albedo * (0.6 + 0.4 * dot(n, light));  // smooth: no max() kink inside a check
  return shaded + 0.1 * reshape(gb.depth, {h, w, 1});
}

}  // namespace

TEST_CASE("pipeline: gradients from pixels to vertices, colours, eye and fov match finite differences",
          "[ops][pipeline][gradcheck]") {
  Scene s = make_scene();
  // Steps of 2e-5 world units move no triangle edge across a pixel centre.
  require_gradcheck("pipeline (positions, colours, eye, fov)",
                    [&](const Inputs& in) { return render(in[0], in[1], s.normals, in[2], in[3], s.triangles); },
                    {s.positions, s.colours, s.eye, s.fov}, GradcheckOptions{1e-5});
}

TEST_CASE("pipeline: gradients are bit-identical for 1 and 2 threads and for shuffled triangles",
          "[ops][pipeline][determinism]") {
  Scene s = make_scene();
  auto gradients = [&](const Tensor& triangles, int threads) {
    set_num_threads(threads);
    s.positions.zero_grad();
    s.colours.zero_grad();
    Tensor image = render(s.positions, s.colours, s.normals, s.eye, s.fov, triangles);
    backward(sum(image * image));
    std::vector<double> g = s.positions.grad().to_vector();
    for (double x : s.colours.grad().to_vector()) g.push_back(x);
    std::vector<double> img = image.to_vector();
    g.insert(g.end(), img.begin(), img.end());
    return g;
  };
  const auto one = gradients(s.triangles, 1);
  const auto two = gradients(s.triangles, 2);
  // Reverse the triangle order: same image and gradients, bit for bit.
  const std::int64_t m = s.triangles.size(0);
  std::vector<std::int32_t> reversed(static_cast<std::size_t>(m * 3));
  const std::int32_t* t = s.triangles.data<std::int32_t>();
  for (std::int64_t k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c) reversed[(m - 1 - k) * 3 + c] = t[k * 3 + c];
  const auto shuffled = gradients(Tensor::from_vector(reversed, {m, 3}), 2);
  set_num_threads(0);
  CHECK(one == two);
  CHECK(one == shuffled);
}
