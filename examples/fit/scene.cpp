// Builds the fit example's scene: reference object and its texture, the start
// sphere, cameras and lights. Plain C++ on tensor storage; nothing here is
// recorded on the tape.
#include "examples/fit/scene.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"

namespace fit {

using namespace gr;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Moves the bounding-box centre to the origin and scales the farthest point to radius 1.
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
  if (!(radius > 0)) throw ValueError("fit: the mesh has no extent");
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) p[3 * i + k] = float((p[3 * i + k] - 0.5 * (lo[k] + hi[k])) / radius);
}

// The colour pattern on the unit direction (x, y, z).
std::array<float, 3> pattern(double x, double y, double z) {
  const std::array<double, 3> warm{0.95, 0.55, 0.15}, cool{0.10, 0.45, 0.70}, pale{0.95, 0.92, 0.85};
  const double longitude = std::atan2(x, z);
  const double band = 0.5 + 0.5 * std::sin(7 * y + 2 * std::sin(3 * longitude));  // wavy latitude stripes
  const double spots = std::pow(0.5 + 0.5 * std::cos(4 * longitude) * std::cos(6 * y), 4.0);
  std::array<float, 3> c;
  for (int k = 0; k < 3; ++k) c[k] = float((band * warm[k] + (1 - band) * cool[k]) * (1 - spots) + spots * pale[k]);
  return c;
}

}  // namespace

double builtin_radius(double x, double y, double z) {
  const double lobes = 0.35 * y * y - 0.22 * std::exp(-y * y / 0.08);  // two lobes along y and a waist
  const double bumps = 0.10 * std::sin(3 * x + 0.5) * std::sin(3 * y + 1.0) * std::sin(3 * z) +
                       0.06 * std::cos(5 * std::atan2(z, x)) * (1 - y * y);
  const double lean = 0.12 * x * (1 + y);  // breaks the symmetries (the pose fit needs that)
  return 0.85 + lobes + bumps + lean;
}

SurfaceMesh make_builtin_object(int subdivisions) {
  SurfaceMesh s = sphere_surface(subdivisions, 1.0);
  float* p = s.positions.data<float>();
  for (std::int64_t i = 0; i < s.num_points(); ++i) {
    const double r = builtin_radius(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    for (int k = 0; k < 3; ++k) p[3 * i + k] = float(p[3 * i + k] * r);
  }
  fit_in_unit_sphere(s.positions);
  return s;
}

SurfaceMesh load_reference_object(const std::string& path, std::string* texture_path,
                                  std::vector<std::string>* warnings, std::vector<std::string>* material_files) {
  const raster::Mesh loaded = raster::load_obj(path);
  SurfaceMesh s = make_surface(loaded);
  fit_in_unit_sphere(s.positions);
  if (texture_path) *texture_path = loaded.texture_path;
  if (warnings) warnings->insert(warnings->end(), loaded.warnings.begin(), loaded.warnings.end());
  if (material_files)
    material_files->insert(material_files->end(), loaded.material_files.begin(), loaded.material_files.end());
  return s;
}

Tensor striped_texture(int height) {
  const int width = 2 * height;
  std::vector<float> texels(static_cast<std::size_t>(3) * width * height);
  for (int j = 0; j < height; ++j)
    for (int i = 0; i < width; ++i) {
      // Texel centre -> (u, v) -> direction (the inverse of sphere_surface's uv map).
      const double u = (i + 0.5) / width, v = 1 - (j + 0.5) / height;
      const double longitude = (u - 0.5) * 2 * kPi, latitude = (v - 0.5) * kPi;
      const auto c = pattern(std::cos(latitude) * std::sin(longitude), std::sin(latitude),
                             std::cos(latitude) * std::cos(longitude));
      std::copy(c.begin(), c.end(), texels.begin() + 3 * (std::size_t(j) * width + i));
    }
  return Tensor::from_vector(texels, {height, width, 3});
}

Tensor striped_colours(const Tensor& positions) {
  const float* p = positions.data<float>();
  const std::int64_t n = positions.size(0);
  std::vector<float> colours(static_cast<std::size_t>(3 * n));
  for (std::int64_t i = 0; i < n; ++i) {
    const double r = std::sqrt(p[3 * i] * p[3 * i] + p[3 * i + 1] * p[3 * i + 1] + p[3 * i + 2] * p[3 * i + 2]) + 1e-12;
    const auto c = pattern(p[3 * i] / r, p[3 * i + 1] / r, p[3 * i + 2] / r);
    std::copy(c.begin(), c.end(), colours.begin() + 3 * i);
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
    cameras.push_back({look_at(eye, origin, up), projection, light});
  }
  return cameras;
}

Scene make_scene(const SceneOptions& options) {
  if (options.views < 1) throw ValueError("fit: need at least one view");
  Scene scene;
  if (options.mesh_path.empty()) {
    if (!options.texture_path.empty())
      throw ValueError("--texture: applies only with --mesh (the built-in object wears its own pattern)");
    scene.name = "built-in lobed blob";
    scene.reference = make_builtin_object(options.reference_subdivisions);
    scene.reference_material.texture = striped_texture(256);
  } else {
    scene.name = options.mesh_path;
    scene.files_read.push_back(options.mesh_path);
    std::string texture_path;
    scene.reference = load_reference_object(options.mesh_path, &texture_path, &scene.warnings, &scene.files_read);
    const bool named_by_mtl = options.texture_path.empty();
    if (!named_by_mtl) texture_path = options.texture_path;
    const bool has_uvs = scene.reference.uvs.defined();
    // An explicit --texture that cannot be applied is refused; a texture the
    // OBJ's MTL names (or fails to name) falls back to the pattern, with a warning.
    if (!named_by_mtl && !has_uvs)
      throw ValueError("--texture '" + options.texture_path + "': the mesh '" + options.mesh_path +
                       "' has no texture coordinates (vt), so a texture cannot be applied to it");
    if (has_uvs && !texture_path.empty()) {
      scene.reference_material.texture = raster::read_image(texture_path, 3);
      scene.files_read.push_back(texture_path);
      scene.name += " with " + texture_path;
    } else {
      scene.reference_material.point_colours = striped_colours(scene.reference.positions);
      const std::string mesh = "'" + options.mesh_path + "'";
      if (!texture_path.empty())
        scene.warnings.push_back("the texture '" + texture_path + "' named by " + mesh +
                                 "'s MTL is not used: the mesh has no texture coordinates (vt); it wears the "
                                 "procedural stripe pattern");
      else if (has_uvs)
        scene.warnings.push_back("the mesh " + mesh +
                                 " has texture coordinates but no texture was found (no MTL map_Kd that exists, "
                                 "no --texture); it wears the procedural stripe pattern");
    }
  }
  scene.start = sphere_surface(options.start_subdivisions, options.start_radius);
  scene.cameras = orbit_cameras(options.views);
  scene.background = Tensor::from_values({0.92, 0.94, 1.0}, {3});
  return scene;
}

}  // namespace fit
