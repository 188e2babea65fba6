// Builds the fit example's scene: reference object, colour pattern, start
// point and cameras. Plain C++ on tensor storage; nothing here is recorded on
// the tape.
#include "examples/fit/scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "autodiff/error.h"
#include "autodiff/tape.h"
#include "examples/fit/geometry.h"
#include "ops/ops.h"
#include "raster/obj_io.h"
#include "raster/procedural.h"

namespace fit {

using namespace gr;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Moves the bounding-box centre to the origin and scales the farthest vertex to radius 1.
void fit_in_unit_sphere(Tensor& positions) {
  float* p = positions.data<float>();
  const std::int64_t n = positions.size(0);
  std::array<double, 3> lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], double(p[3 * i + k])), hi[k] = std::max(hi[k], double(p[3 * i + k]));
  double radius = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    double r2 = 0;
    for (int k = 0; k < 3; ++k) r2 += std::pow(p[3 * i + k] - 0.5 * (lo[k] + hi[k]), 2);
    radius = std::max(radius, std::sqrt(r2));
  }
  if (radius <= 0) throw ValueError("fit: the mesh has no extent");
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) p[3 * i + k] = float((p[3 * i + k] - 0.5 * (lo[k] + hi[k])) / radius);
}

// Smooth random offsets along the vertex normals, largest magnitude = depth.
Tensor dented(const Tensor& positions, const Tensor& triangles, double depth, std::uint64_t seed) {
  NoGradGuard no_grad;
  const std::int64_t n = positions.size(0);
  const UniformLaplacian laplacian(triangles, n);
  Tensor noise = Tensor::uniform({n, 1}, -1.0, 1.0, seed);
  for (int pass = 0; pass < 8; ++pass) noise = noise - laplacian.apply(noise);  // neighbour averages
  double peak = 0;
  for (double x : noise.to_vector()) peak = std::max(peak, std::abs(x));
  return positions + vertex_normals(positions, triangles) * noise * (depth / std::max(peak, 1e-12));
}

}  // namespace

raster::Mesh make_builtin_object() {
  raster::Mesh mesh = raster::make_icosphere(4);
  float* p = mesh.positions.data<float>();
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i) {
    const double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
    const double bumps = 0.12 * std::sin(3 * x + 0.5) * std::sin(3 * y + 1.0) * std::sin(3 * z) +
                         0.06 * std::cos(5 * std::atan2(z, x)) * (1 - y * y);
    for (int k = 0; k < 3; ++k) p[3 * i + k] *= float(1 + bumps);
  }
  fit_in_unit_sphere(mesh.positions);
  mesh.normals = Tensor();  // stale after the bumps
  return mesh;
}

raster::Mesh load_reference_object(const std::string& path) {
  const raster::Mesh loaded = raster::load_obj(path);
  const float* p = loaded.positions.data<float>();
  std::map<std::array<float, 3>, std::int32_t> index_of;
  std::vector<float> positions;
  std::vector<std::int32_t> remap(static_cast<std::size_t>(loaded.num_vertices()));
  for (std::int64_t i = 0; i < loaded.num_vertices(); ++i) {
    const std::array<float, 3> key{p[3 * i], p[3 * i + 1], p[3 * i + 2]};
    auto [it, inserted] = index_of.emplace(key, static_cast<std::int32_t>(index_of.size()));
    if (inserted) positions.insert(positions.end(), key.begin(), key.end());
    remap[i] = it->second;
  }
  std::vector<std::int32_t> triangles;
  const std::int32_t* t = loaded.triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < loaded.num_triangles(); ++f) {
    const std::int32_t a = remap[t[3 * f]], b = remap[t[3 * f + 1]], c = remap[t[3 * f + 2]];
    if (a != b && b != c && a != c) triangles.insert(triangles.end(), {a, b, c});
  }
  if (triangles.empty()) throw ValueError("fit: " + path + " has no non-degenerate triangle");
  raster::Mesh mesh;
  mesh.positions = Tensor::from_vector(positions, {std::int64_t(positions.size() / 3), 3});
  mesh.triangles = Tensor::from_vector(triangles, {std::int64_t(triangles.size() / 3), 3});
  fit_in_unit_sphere(mesh.positions);
  return mesh;
}

Tensor striped_colours(const Tensor& positions) {
  const std::array<double, 3> warm{0.95, 0.55, 0.15}, cool{0.10, 0.55, 0.70}, pale{0.90, 0.88, 0.80};
  const float* p = positions.data<float>();
  const std::int64_t n = positions.size(0);
  std::vector<float> colours(static_cast<std::size_t>(3 * n));
  for (std::int64_t i = 0; i < n; ++i) {
    const double r = std::sqrt(p[3 * i] * p[3 * i] + p[3 * i + 1] * p[3 * i + 1] + p[3 * i + 2] * p[3 * i + 2]) + 1e-12;
    const double x = p[3 * i] / r, y = p[3 * i + 1] / r, z = p[3 * i + 2] / r;
    const double longitude = std::atan2(z, x);
    const double band = 0.5 + 0.5 * std::sin(7 * y + 2 * std::sin(3 * longitude));  // wavy latitude stripes
    const double spots = std::pow(0.5 + 0.5 * std::cos(4 * longitude) * std::cos(6 * y), 4.0);
    for (int k = 0; k < 3; ++k)
      colours[3 * i + k] = float((band * warm[k] + (1 - band) * cool[k]) * (1 - spots) + spots * pale[k]);
  }
  return Tensor::from_vector(colours, {n, 3});
}

std::vector<Camera> orbit_cameras(int views) {
  NoGradGuard no_grad;
  std::vector<Camera> cameras;
  const Tensor projection = perspective(0.8, 1.0, 0.5, 10.0);
  const Tensor origin = Tensor::zeros({3}), up = Tensor::from_values({0, 1, 0}, {3});
  for (int v = 0; v < views; ++v) {
    const double azimuth = 0.3 + 2 * kPi * v / views;
    const double elevation = (v % 2 == 0 ? 25.0 : -15.0) * kPi / 180;
    const double cx = std::cos(elevation) * std::sin(azimuth), cy = std::sin(elevation),
                 cz = std::cos(elevation) * std::cos(azimuth);
    const Tensor eye = Tensor::from_values({3.2 * cx, 3.2 * cy, 3.2 * cz}, {3});
    // The light sits above and to the left of the camera.
    const Tensor light = normalize(Tensor::from_values({cx - 0.4 * cz, cy + 0.6, cz + 0.4 * cx}, {3}));
    cameras.push_back({matmul(projection, look_at(eye, origin, up)), light});
  }
  return cameras;
}

Scene make_scene(const SceneOptions& options) {
  if (options.views < 1) throw ValueError("fit: need at least one view");
  const raster::Mesh mesh =
      options.mesh_path.empty() ? make_builtin_object() : load_reference_object(options.mesh_path);
  Scene scene;
  scene.name = options.mesh_path.empty() ? "built-in bumpy icosphere" : options.mesh_path;
  scene.triangles = mesh.triangles;
  scene.reference_positions = mesh.positions;
  scene.reference_colours = striped_colours(mesh.positions);
  scene.start_positions = dented(mesh.positions, mesh.triangles, options.dent_depth, options.seed);
  scene.start_colours = Tensor::full({mesh.num_vertices(), 3}, 0.5);
  scene.cameras = orbit_cameras(options.views);
  return scene;
}

}  // namespace fit
