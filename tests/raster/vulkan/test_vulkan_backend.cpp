// A Vulkan device as the ops' execution context (raster/vulkan/backend.h):
// rasterize with RasterizeOptions::backend gives the CPU op's G-buffer bit for
// bit and, with interpolate, antialias and the rasterize adjoint on the
// device too, the image bit for bit on lavapipe and the gradients within 1e-5;
// depth peeling gives the CPU's layers bit for bit (one image and a batch);
// the fit example with its G-buffers on the GPU (gradraster-fit --device
// vulkan) gives the CPU run's loss and IoU exactly (its gradients come out bit
// for bit the CPU's here: the fixed-point sums round to the CPU's double
// sums), and gradraster-render --device vulkan writes the CPU run's files
// byte for byte. A G-buffer made with row 0 at the bottom (the Python
// binding's) is read from the device by interpolate, and reserve_frames lets
// a backend keep more G-buffers at once. The whole chain on hard scenes:
// test_vulkan_backend_chain.cpp.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "examples/fit/fit.h"
#include "examples/render/render_tool.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/scenes.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::testing;

namespace {

bool same_bits(const Tensor& a, const Tensor& b) {
  return a.numel() == b.numel() && std::memcmp(a.data<float>(), b.data<float>(), a.numel() * 4) == 0;
}

}  // namespace

TEST_CASE("rasterize on a Vulkan backend gives the CPU op's G-buffer bit for bit and its gradients", "[vulkan]") {
  if (!shared_gpu()) return;
  const raster::Mesh mesh = raster::make_torus(40, 20);
  const Tensor view = look_at(Tensor::from_values({0.4, 1.6, 2.2}, {3}), Tensor::zeros({3}),
                              Tensor::from_values({0, 1, 0}, {3}));
  const Tensor mvp = matmul(perspective(0.9, 1.0, 0.3, 10.0), view);
  RasterizeOptions gpu{96, 80};
  gpu.backend = vulkan::raster_backend(shared_gpu());
  CHECK(gpu.backend->name().find("vulkan") == 0);
  const Tensor colours = Tensor::uniform({mesh.num_vertices(), 3}, 0, 1, 5);
  Tensor grads[2], images[2];
  GBuffer gbs[2];
  for (int run = 0; run < 2; ++run) {
    Tensor positions = mesh.positions.copy().set_requires_grad();
    const Tensor clip = transform_points(positions, mvp);
    gbs[run] = rasterize(clip, mesh.triangles, run == 0 ? RasterizeOptions{96, 80} : gpu);
    const Tensor image = antialias(interpolate(colours, gbs[run], mesh.triangles), gbs[run], clip, mesh.triangles);
    backward(sum(pow(image, 2.0)));
    grads[run] = positions.grad();
    images[run] = image;
  }
  REQUIRE(std::memcmp(gbs[0].tri_id.data<std::int32_t>(), gbs[1].tri_id.data<std::int32_t>(), 96 * 80 * 4) == 0);
  REQUIRE(same_bits(gbs[0].uv, gbs[1].uv));
  REQUIRE(same_bits(gbs[0].depth, gbs[1].depth));
  const auto values = [](const Tensor& t) { return std::vector<float>(t.data<float>(), t.data<float>() + t.numel()); };
  CHECK(relative_error(values(images[1]), values(images[0])) <= 1e-6);
  CHECK(relative_error(values(grads[1]), values(grads[0])) <= 1e-5);
}

TEST_CASE("depth peeling on a Vulkan backend gives the CPU's layers bit for bit and its gradients, one image or a batch",
          "[vulkan]") {
  if (!shared_gpu()) return;
  const raster::Mesh mesh = raster::make_torus(30, 16);
  const Tensor view = look_at(Tensor::from_values({0.3, 1.2, 2.4}, {3}), Tensor::zeros({3}),
                              Tensor::from_values({0, 1, 0}, {3}));
  const Tensor mvp = matmul(perspective(0.9, 1.0, 0.3, 10.0), view);
  RasterizeOptions gpu{64, 56};
  gpu.backend = vulkan::raster_backend(shared_gpu());
  const Tensor colours = Tensor::uniform({mesh.num_vertices(), 3}, 0, 1, 8);
  for (bool batch : {false, true}) {
    INFO((batch ? "instanced batch of 2" : "one image"));
    GBuffer layers[2][4];
    Tensor grads[2];
    for (int run = 0; run < 2; ++run) {
      Tensor positions = mesh.positions.copy().set_requires_grad();
      Tensor clip = transform_points(positions, mvp);
      if (batch) clip = stack({clip, clip * 1.01}, 0);
      const RasterizeOptions options = run == 0 ? RasterizeOptions{64, 56} : gpu;
      DepthPeeler peeler = batch ? DepthPeeler::instanced(clip, mesh.triangles, options)
                                 : DepthPeeler(clip, mesh.triangles, options);
      Tensor loss = Tensor::zeros({});
      for (int k = 0; k < 4; ++k) {
        layers[run][k] = peeler.rasterize_next_layer();
        const Tensor shaded = batch ? interpolate_batch(colours, layers[run][k], mesh.triangles)
                                    : interpolate(colours, layers[run][k], mesh.triangles);
        loss = loss + sum(pow(shaded, 2.0)) * double(k + 1);
      }
      backward(loss);
      grads[run] = positions.grad();
    }
    for (int k = 0; k < 4; ++k) {
      INFO("layer " << k);
      const Tensor& a = layers[0][k].tri_id;
      REQUIRE(std::memcmp(a.data<std::int32_t>(), layers[1][k].tri_id.data<std::int32_t>(), a.numel() * 4) == 0);
      REQUIRE(same_bits(layers[0][k].uv, layers[1][k].uv));
      REQUIRE(same_bits(layers[0][k].depth, layers[1][k].depth));
    }
    std::int64_t second = 0;
    for (std::int64_t i = 0; i < layers[0][1].tri_id.numel(); ++i) second += layers[0][1].tri_id.data<std::int32_t>()[i] > 0;
    CHECK(second > 0);  // the torus has a second layer somewhere
    const auto values = [](const Tensor& t) { return std::vector<float>(t.data<float>(), t.data<float>() + t.numel()); };
    CHECK(relative_error(values(grads[1]), values(grads[0])) <= 1e-5);
  }
}

TEST_CASE("the fit example with its G-buffers on the GPU gives the CPU run's loss and IoU exactly", "[vulkan]") {
  if (!shared_gpu()) return;
  TempDir dir;
  fit::FitOptions options;
  options.iterations = 8;
  options.size = 40;
  options.views = 2;
  options.start_subdivisions = 2;
  options.reference_subdivisions = 3;
  options.write_outputs = false;
  options.progress_bar = false;
  options.out_dir = dir.file("out");
  std::ostringstream log;
  const fit::FitResult cpu = fit::run_fit(options, log);
  options.raster_backend = vulkan::raster_backend(shared_gpu());
  const fit::FitResult gpu = fit::run_fit(options, log);
  CHECK(gpu.final_loss == cpu.final_loss);
  CHECK(gpu.final_iou == cpu.final_iou);
  CHECK(gpu.losses == cpu.losses);
}

TEST_CASE("gradraster-render --device vulkan writes the CPU run's image and G-buffer byte for byte", "[vulkan]") {
  if (!shared_gpu()) return;
  TempDir dir;
  auto run = [&](const std::string& device) {
    std::ostringstream out, err;
    const int code = render_tool::run_render_tool(
        {"--builtin", "torus", "--width", "80", "--height", "60", "--eye", "0.5,1.5,2.5", "--out",
         dir.file(device + ".png"), "--out-triid", dir.file(device + ".tri"), "--out-depth", dir.file(device + ".depth"),
         "--device", device},
        out, err);
    INFO(err.str());
    REQUIRE(code == 0);
    return out.str();
  };
  auto bytes = [&](const std::string& name) {
    std::ifstream f(dir.file(name), std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  run("cpu");
  CHECK(run("vulkan").find("device=\"vulkan: ") != std::string::npos);
  for (const char* ext : {".png", ".tri", ".depth"}) {
    INFO(ext);
    CHECK(bytes(std::string("vulkan") + ext) == bytes(std::string("cpu") + ext));
    CHECK(!bytes(std::string("cpu") + ext).empty());
  }
}

namespace {

// One image's G-buffer made by `backend` with row 0 at the bottom (y_up, as
// the Python binding's), as rast (u, v, z/w, id) and db, and its handle.
struct KeptImage {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv, depth, rast, db;
  std::shared_ptr<const raster::DeviceGBuffer> handle;
};

KeptImage keep_y_up(const raster::RasterBackend& backend, const Scene& s, int W, int H) {
  raster::RasterParams<float> p = s.params(W, H);
  p.settings.y_up = true;
  const std::size_t px = static_cast<std::size_t>(W) * H;
  KeptImage k{std::vector<std::int32_t>(px), std::vector<float>(2 * px), std::vector<float>(px),
              std::vector<float>(4 * px), std::vector<float>(4 * px), nullptr};
  k.handle = backend.rasterize_gbuffer(p, k.tri_id.data(), k.uv.data(), k.depth.data(), k.db.data(), nullptr);
  for (std::size_t q = 0; q < px; ++q) {
    if (!k.tri_id[q]) continue;
    const float values[] = {k.uv[2 * q], k.uv[2 * q + 1], k.depth[q], float(k.tri_id[q])};
    std::copy(values, values + 4, k.rast.begin() + 4 * q);
  }
  return k;
}

// interpolate_forward of attr (3 channels, all differentiated) on k's
// handle: on `backend` (out, then out_da appended), or the CPU kernel.
std::vector<float> interpolate_kept(const raster::RasterBackend* backend, const Scene& s, const KeptImage& k,
                                    const std::vector<float>& attr, int W, int H) {
  const std::int32_t diff[] = {0, 1, 2};
  raster::BarycentricInterpolateParams<float> p;
  p.attr = attr.data();
  p.num_vertices = static_cast<std::int64_t>(s.clip.size() / 4);
  p.channels = 3;
  p.tris = s.tris.data();
  p.num_tris = static_cast<std::int64_t>(s.tris.size() / 3);
  p.rast = k.rast.data();
  p.pixels = std::int64_t(W) * H;
  p.rast_db = k.db.data();
  p.diff = diff;
  p.num_diff = 3;
  p.tri_id = k.tri_id.data();
  std::vector<float> out(static_cast<std::size_t>(9 * p.pixels));
  float* out_da = out.data() + 3 * p.pixels;
  if (backend)
    REQUIRE(backend->interpolate_forward(k.handle.get(), p, W, H, out.data(), out_da, nullptr));
  else
    raster::barycentric_interpolate_forward(p, out.data(), out_da);
  return out;
}

}  // namespace

TEST_CASE("interpolate reads a G-buffer made with row 0 at the bottom from the device, with the CPU's values",
          "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = random_soup(60, 8);
  const std::vector<float> attr = random_values(s.clip.size() / 4 * 3, 9);
  const auto backend = vulkan::raster_backend(shared_gpu());
  const KeptImage k = keep_y_up(*backend, s, 40, 32);
  REQUIRE(k.handle);
  CHECK(relative_error(interpolate_kept(backend.get(), s, k, attr, 40, 32),
                       interpolate_kept(nullptr, s, k, attr, 40, 32)) <= 1e-6);
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.resident_calls == 1);
  CHECK(stats.uploads == 0);
}

TEST_CASE("reserve_frames lets a backend keep more G-buffers at once, never fewer", "[vulkan]") {
  if (!shared_gpu()) return;
  const std::vector<Scene> scenes = {random_soup(40, 10), random_soup(40, 11), random_soup(40, 12)};
  const std::vector<float> attr = random_values(scenes[0].clip.size() / 4 * 3, 13);
  const auto backend = vulkan::raster_backend(shared_gpu(), 1);
  vulkan::reserve_frames(*backend, 3);
  vulkan::reserve_frames(*backend, 2);  // no shrinking
  std::vector<KeptImage> kept;
  for (const Scene& s : scenes) kept.push_back(keep_y_up(*backend, s, 24, 24));
  for (std::size_t i = 0; i < scenes.size(); ++i)
    CHECK(relative_error(interpolate_kept(backend.get(), scenes[i], kept[i], attr, 24, 24),
                         interpolate_kept(nullptr, scenes[i], kept[i], attr, 24, 24)) <= 1e-6);
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.frames == 3);
  CHECK(stats.resident_calls == 3);
  CHECK(stats.uploads == 0);
}
