// Every per-pixel GPU pass beyond 2^24 pixels, where dispatch() stacks a
// second row of workgroups (65535 x 256 invocations per row), against the CPU
// kernels on a 4111 x 4100 image: the G-buffer (with rast_db) bit for bit,
// interpolate (with attribute derivatives) and antialias values within 1e-6,
// every adjoint's gradients within 1e-5 of the largest (the G-buffer's
// through the chain left on the device). The scene covers the first and the last rows of pixels (a far
// quad over the whole view behind a soup crossing the near plane). Before
// shaders/dispatch.glsl, the second row's invocations took items 65535 +
// their x index: most pixels ran twice (the fixed-point sums came out wrong)
// and those from 65535 x 257 on (the last 12,605 here) never ran. On
// lavapipe (2 cores) this takes about a minute and 3 GB.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <vector>

#include "raster/antialias.h"
#include "raster/barycentric_interpolate.h"
#include "raster/rasterize.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

constexpr int kWidth = 4111, kHeight = 4100;
constexpr std::int64_t kPixels = std::int64_t(kWidth) * kHeight;
static_assert(kPixels > std::int64_t(65535) * 256, "one row of workgroups would do");

// A random soup in front of a quad over the whole view (at depth 0.9).
Scene soup_before_a_far_quad() {
  Scene s = random_soup(40, 7);
  const std::int32_t q = static_cast<std::int32_t>(s.clip.size() / 4);
  for (float y : {-1.5f, 1.5f})
    for (float x : {-1.5f, 1.5f}) s.clip.insert(s.clip.end(), {x, y, 0.9f, 1.0f});
  s.tris.insert(s.tris.end(), {q, q + 1, q + 3, q, q + 3, q + 2});
  return s;
}

template <class T>
std::int64_t differing(const std::vector<T>& a, const std::vector<T>& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

bool any_nonzero(const std::vector<float>& v) {
  return std::any_of(v.begin(), v.end(), [](float x) { return x != 0.0f; });
}

}  // namespace

TEST_CASE("every GPU pass beyond 2^24 pixels (two rows of workgroups) matches the CPU kernels", "[vulkan][large]") {
  if (!shared_gpu()) return;
  const Scene s = soup_before_a_far_quad();
  const RasterParams<float> params = s.params(kWidth, kHeight);
  const std::int64_t N = params.num_vertices;
  vulkan::Frame frame(shared_gpu());

  // Rasterize: the coverage and the G-buffer (with rast_db) bit for bit, the first and last rows covered.
  const CpuGBuffer gb = cpu_gbuffer(s, kWidth, kHeight, false, true);
  REQUIRE(gb.id.front() > 0);
  REQUIRE(gb.id.back() > 0);
  vulkan::GpuRasterOptions options;
  options.derivatives = true;
  {
    std::vector<std::int32_t> gpu_id(kPixels, -7);
    std::vector<float> gpu_rast(4 * kPixels, -7.f), gpu_db(4 * kPixels, -7.f);
    frame.rasterize(params, options, gpu_id.data(), gpu_rast.data(), gpu_db.data());
    CHECK(differing(gpu_id, gb.id) == 0);
    CHECK(differing(gpu_rast, gb.rast) == 0);
    CHECK(differing(gpu_db, gb.db) == 0);
  }

  // Interpolate (one channel, with its derivatives) and its adjoint.
  const std::vector<float> attr = random_values(N, 1), grad_out = random_values(kPixels, 2);
  const std::vector<float> grad_da = random_values(2 * kPixels, 4);
  const std::int32_t diff[1] = {0};
  BarycentricInterpolateParams<float> ip;
  ip.attr = attr.data();
  ip.num_vertices = N;
  ip.channels = 1;
  ip.tris = s.tris.data();
  ip.num_tris = params.num_tris;
  ip.rast = gb.rast.data();
  ip.pixels = kPixels;
  ip.tri_id = gb.id.data();
  ip.rast_db = gb.db.data();
  ip.diff = diff;
  ip.num_diff = 1;
  std::vector<float> image(kPixels), da(2 * kPixels);
  std::vector<float> grad_attr(N), grad_rast(4 * kPixels), grad_db(4 * kPixels);
  barycentric_interpolate_forward(ip, image.data(), da.data());
  barycentric_interpolate_backward(ip, grad_out.data(), grad_da.data(), {nullptr, grad_rast.data(), grad_db.data()});
  {
    // dL/dattr from the float64 kernel on the same float32 inputs: the float32
    // kernel sums each vertex's ~8 million contributions in float (about 1e-4
    // off; the GPU's fixed-point sums are exact to 2^-61 of the largest).
    auto wide = [](const std::vector<float>& v) { return std::vector<double>(v.begin(), v.end()); };
    const std::vector<double> attr64 = wide(attr), rast64 = wide(gb.rast), db64 = wide(gb.db);
    const std::vector<double> grad_out64 = wide(grad_out), grad_da64 = wide(grad_da);
    BarycentricInterpolateParams<double> ip64;
    ip64.attr = attr64.data();
    ip64.num_vertices = N;
    ip64.channels = 1;
    ip64.tris = s.tris.data();
    ip64.num_tris = params.num_tris;
    ip64.rast = rast64.data();
    ip64.pixels = kPixels;
    ip64.tri_id = gb.id.data();
    ip64.rast_db = db64.data();
    ip64.diff = diff;
    ip64.num_diff = 1;
    std::vector<double> grad_attr64(N);
    barycentric_interpolate_backward(ip64, grad_out64.data(), grad_da64.data(), {grad_attr64.data(), nullptr, nullptr});
    grad_attr.assign(grad_attr64.begin(), grad_attr64.end());
  }
  REQUIRE(any_nonzero(grad_attr));
  {
    std::vector<float> out(kPixels), out_da(2 * kPixels), g_attr(N), g_rast(4 * kPixels), g_db(4 * kPixels);
    frame.interpolate(attr.data(), 1, out.data(), diff, 1, out_da.data());
    frame.interpolate_backward(grad_out.data(), grad_da.data(), g_attr.data(), g_rast.data(), g_db.data());
    CHECK(relative_error(out, image) <= 1e-6);
    CHECK(relative_error(out_da, da) <= 1e-6);
    CHECK(relative_error(g_attr, grad_attr) <= 1e-5);
    CHECK(relative_error(g_rast, grad_rast) <= 1e-5);
    CHECK(relative_error(g_db, grad_db) <= 1e-5);
  }
  std::vector<float> depth(kPixels);
  for (std::int64_t q = 0; q < kPixels; ++q) depth[q] = gb.rast[4 * q + 2];

  // Antialias of the interpolated image (left on the device) and its adjoint.
  const EdgeTopology topology = build_edge_topology(s.tris.data(), params.num_tris);
  AntialiasParams<float> ap;
  ap.image = image.data();
  ap.channels = 1;
  ap.width = kWidth;
  ap.height = kHeight;
  ap.tri_id = gb.id.data();
  ap.depth = depth.data();
  ap.clip = s.clip.data();
  ap.num_vertices = N;
  ap.tris = s.tris.data();
  ap.num_tris = params.num_tris;
  ap.topology = &topology;
  {
    std::vector<float> out(kPixels), grad_image(kPixels), aa_grad_clip(4 * N);
    std::vector<AntialiasPair> pairs;
    antialias_forward(ap, out.data(), &pairs);
    REQUIRE(!pairs.empty());
    antialias_backward(ap, pairs, grad_out.data(), AntialiasGrads<float>{grad_image.data(), aa_grad_clip.data()});
    REQUIRE(any_nonzero(aa_grad_clip));
    std::vector<float> g_out(kPixels), g_image(kPixels), g_clip(4 * N);
    frame.antialias(nullptr, 1, g_out.data());
    frame.antialias_backward(grad_out.data(), g_image.data(), g_clip.data());
    CHECK(relative_error(g_out, out) <= 1e-6);
    CHECK(relative_error(g_image, grad_image) <= 1e-5);
    CHECK(relative_error(g_clip, aa_grad_clip) <= 1e-5);
  }

  // The G-buffer's adjoint, from the interpolate adjoint's gradient left on the
  // device and a random dL/d(z/w) from the host.
  std::vector<float> extra(4 * kPixels, 0.0f);
  const std::vector<float> grad_depth = random_values(kPixels, 3);
  for (std::int64_t q = 0; q < kPixels; ++q) extra[4 * q + 2] = grad_depth[q];
  for (std::size_t i = 0; i < extra.size(); ++i) grad_rast[i] += extra[i];
  std::vector<float> cpu(4 * N), gpu(4 * N);
  barycentric_gbuffer_backward(gbuffer_params(s, kWidth, kHeight, false), gb.rast.data(), grad_rast.data(),
                               grad_db.data(), cpu.data());
  REQUIRE(any_nonzero(cpu));
  frame.interpolate_backward(grad_out.data(), grad_da.data());
  frame.rasterize_backward(extra.data(), nullptr, gpu.data());
  CHECK(relative_error(gpu, cpu) <= 1e-5);
}
