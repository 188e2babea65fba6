// gradraster-shading-gallery: renders a UV sphere once and shades it five ways
// with the library's shading functions (ops/shading.h, gr::shading): Lambert |
// Blinn-Phong | normal-mapped Blinn-Phong | Cook-Torrance (GGX) | SH
// sky/ground environment, side by side, into OUT_DIR/shading_gallery.png
// (default OUT_DIR: out). The pipeline is the one to copy: transform ->
// rasterize -> interpolate -> texture -> shade -> composite -> sRGB.
// Everything is a tensor op, so the same code differentiates.
#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "examples/common/output_folder.h"
#include "examples/shading/sky_ground.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/procedural.h"
#include "raster/temporaries.h"

using namespace gr;

namespace {

constexpr int kSize = 256;  // each panel is kSize x kSize
constexpr double kPi = 3.14159265358979323846;

Tensor vec3(double x, double y, double z) { return Tensor::from_values({x, y, z}, {3}); }

// A bumpy normal map: a grid of 24 x 12 round bumps in (u, v) (square cells
// on a sphere, whose u spans twice the length of v). In cell coordinates
// (x, y) in [-1/2, 1/2]^2 with d^2 = x^2 + y^2, a bump of radius R has height
// h = (1 - d^2/R^2)^2 for d < R; the tangent-space normal is
// n = normalize(-s dh/dx, -s dh/dy, 1), encoded as texels (n + 1) / 2.
// Row 0 is the top of the texture (v = 1).
Tensor bumpy_normal_map(int width, int height, double strength) {
  constexpr double kRadius = 0.4;
  std::vector<double> texels;
  texels.reserve(static_cast<std::size_t>(width) * height * 3);
  for (int row = 0; row < height; ++row)
    for (int col = 0; col < width; ++col) {
      const double u = (col + 0.5) / width, v = 1.0 - (row + 0.5) / height;
      const double x = 24 * u - std::floor(24 * u) - 0.5, y = 12 * v - std::floor(12 * v) - 0.5;
      const double falloff = std::max(0.0, 1.0 - (x * x + y * y) / (kRadius * kRadius));
      const double dh = -4 * falloff / (kRadius * kRadius);  // dh/dx = dh * x, dh/dy = dh * y
      const double nx = -strength * dh * x, ny = -strength * dh * y;
      const double len = std::sqrt(nx * nx + ny * ny + 1.0);
      for (double c : {nx / len, ny / len, 1.0 / len}) texels.push_back(0.5 * (c + 1.0));
    }
  return Tensor::from_values(texels, {height, width, 3});
}

// A vertical background gradient [kSize, kSize, 3], lighter at the top.
Tensor background() {
  std::vector<double> px;
  px.reserve(kSize * kSize * 3);
  for (int row = 0; row < kSize; ++row) {
    const double t = static_cast<double>(row) / (kSize - 1);
    for (int col = 0; col < kSize; ++col)
      for (double c : {0.16, 0.17, 0.20}) px.push_back(c * (1.4 - 0.8 * t));
  }
  return Tensor::from_values(px, {kSize, kSize, 3});
}

int run(const std::string& out_dir) {
  // Scene: a UV sphere (positions, normals, uvs) and its tangent frames [V, 4].
  const raster::Mesh mesh = raster::make_uv_sphere(64, 128);
  const Tensor tangents = shading::vertex_tangents(mesh.positions, mesh.uvs, mesh.triangles, mesh.normals);
  const Tensor eye = vec3(0.0, 0.9, 3.9);
  const Tensor view = look_at(eye, vec3(0, 0, 0), vec3(0, 1, 0));
  const Tensor clip = transform_points(mesh.positions, matmul(perspective(36 * kPi / 180, 1.0, 0.1, 20.0), view));

  // Rasterize once; interpolate everything the shaders need per pixel.
  RasterizeOptions raster{kSize, kSize};
  raster.derivatives = true;  // the uv derivatives of the textures' level of detail
  const GBuffer gb = rasterize(clip, mesh.triangles, raster);
  const Tensor normal = normalize(interpolate(mesh.normals, gb, mesh.triangles));  // [H, W, 3]
  const Tensor position = interpolate(mesh.positions, gb, mesh.triangles);
  const Tensor tangent = interpolate(tangents, gb, mesh.triangles);  // [H, W, 4]
  const InterpolatedWithDerivatives uv = interpolate_with_derivatives(mesh.uvs, gb, mesh.triangles);
  const Tensor view_dir = normalize(eye - position);

  // Materials and lights: a directional light of radiance pi (so Lambert's
  // brightest value is the albedo) and a point light of the same radiance at
  // about 5 units from the sphere.
  const Tensor albedo = vec3(0.80, 0.62, 0.50);
  const Tensor specular = vec3(0.2, 0.2, 0.2);
  const Tensor shininess = Tensor::scalar(40.0);
  const Tensor metallic = Tensor::scalar(0.0), roughness = Tensor::scalar(0.35);
  const shading::LightSample sun = shading::directional_light(vec3(-0.6, 0.7, 0.6), vec3(kPi, kPi, kPi));
  const shading::LightSample lamp = shading::point_light(vec3(-3.0, 3.5, 3.5), vec3(25 * kPi, 25 * kPi, 25 * kPi),
                                                         position);
  const Tensor sh =
      shading_example::sh_sky_ground(vec3(0, 1, 0), vec3(0.55, 0.72, 1.0), vec3(0.40, 0.28, 0.16));

  // Normal mapping: a trilinear lookup of the tangent-space map, then perturb.
  TextureOptions tex_options;
  tex_options.filter = Filter::Trilinear;
  const Tensor texel = texture(bumpy_normal_map(1024, 512, 0.25), uv.values, tex_options, uv.d_dx, uv.d_dy);
  const Tensor bumped = shading::perturb_normal(normal, tangent, texel);

  const std::vector<Tensor> shaded = {
      shading::lambert(albedo, normal, sun.direction) * sun.radiance,
      shading::blinn_phong(albedo, specular, shininess, normal, lamp.direction, view_dir) * lamp.radiance,
      shading::blinn_phong(albedo, specular, shininess, bumped, lamp.direction, view_dir) * lamp.radiance,
      shading::cook_torrance(albedo, metallic, roughness, normal, lamp.direction, view_dir) * lamp.radiance,
      shading::sh_diffuse(albedo, normal, sh),
  };

  // Composite over the background where a triangle covers the pixel, then
  // encode to sRGB (linear -> display) and lay the panels out with gutters.
  const Tensor covered = reshape(greater(cast(gb.tri_id, DType::Float32), Tensor::scalar(0.0)), {kSize, kSize, 1});
  const Tensor bg = background();
  const Tensor gutter = Tensor::full({kSize, 4, 3}, 0.02);
  std::vector<Tensor> row;
  for (const Tensor& colour : shaded) {
    if (!row.empty()) row.push_back(gutter);
    row.push_back(shading::linear_to_srgb(clamp(where(covered, colour, bg), 0.0, 1.0)));
  }
  cli::OutputFolder folder(out_dir);  // a failed or interrupted run leaves no new empty folder
  folder.create();
  const std::string path = (std::filesystem::path(out_dir) / "shading_gallery.png").string();
  raster::write_png(path, concat(row, 1));
  folder.keep();
  std::cout << "wrote " << path << " (" << 5 * kSize + 16 << "x" << kSize
            << "): Lambert | Blinn-Phong | normal-mapped Blinn-Phong | Cook-Torrance | SH sky/ground\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  raster::remove_temporaries_on_signals();  // Ctrl-C leaves no partial file behind
  const std::string program = argc > 0 ? argv[0] : "gradraster-shading-gallery";
  const std::vector<std::string> args(argv + 1, argv + argc);
  const std::string usage = "usage: " + program + " [OUT_DIR]\n" +
                            "Renders a sphere with five shaders (Lambert, Blinn-Phong, normal mapping,\n" +
                            "Cook-Torrance, SH environment) side by side into OUT_DIR/shading_gallery.png\n" +
                            "(default OUT_DIR: out).\n";
  if (args.size() == 1 && (args[0] == "-h" || args[0] == "--help")) {
    std::cout << usage;
    return 0;
  }
  if (args.size() > 1 || (args.size() == 1 && args[0].rfind("-", 0) == 0)) {
    std::cerr << program << ": expected at most one argument, an output directory\n\n" << usage;
    return 2;
  }
  try {
    return run(args.empty() ? "out" : args[0]);
  } catch (const std::exception& e) {
    std::cerr << program << ": " << e.what() << "\n";
    return 1;
  }
}
