// The cube_texture op on a Vulkan backend keeps its cube map on the device
// (raster/vulkan/texture.h's KeptTexels, ops/render/resident_texture.h), as
// the texture op does: the forward and adjoint of one call upload the 6 faces
// once, so do several calls on an unchanged cube map; one written in place is
// uploaded again and its new values used; the same tensor read as a cube map
// and as 2D textures keeps a copy of each. And the per-face mip levels the
// device builds from level 0 (texture_mip.comp) are cube_mip_build's: the
// lookups and gradients with them are those with the CPU's levels uploaded,
// bit for bit. Every result is compared bit for bit with the same lookups on a
// fresh backend and tensor (uploaded), and with the CPU op within issue 33's
// tolerances.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "ops/ops.h"
#include "raster/cube_texture.h"
#include "raster/mipmap.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/cube_texture.h"
#include "raster/vulkan/scenes.h"
#include "raster/vulkan/texture.h"

using namespace gr;
using namespace gr::testing;

namespace {

std::vector<float> values(const Tensor& t) { return std::vector<float>(t.data<float>(), t.data<float>() + t.numel()); }

// A new leaf with t's values (another storage).
Tensor fresh(const Tensor& t) {
  const std::vector<float> v = values(t);
  return Tensor::from_values(std::vector<double>(v.begin(), v.end()), t.shape()).set_requires_grad();
}

// One view's trilinear cube-map lookups (seeded by view) and every gradient.
struct View {
  std::vector<float> out, g_tex, g_dir, g_da, g_bias;
  bool operator==(const View& o) const {
    return out == o.out && g_tex == o.g_tex && g_dir == o.g_dir && g_da == o.g_da && g_bias == o.g_bias;
  }
};

View render_view(Tensor tex, int view, const CubeTextureOptions& options) {
  Tensor dir = Tensor::uniform({24, 16, 3}, -1, 1, 10 + view).set_requires_grad();
  Tensor da = Tensor::uniform({24, 16, 6}, -0.08, 0.08, 20 + view).set_requires_grad();
  Tensor bias = Tensor::uniform({24, 16}, -1, 2, 30 + view).set_requires_grad();
  Tensor out = cube_texture(tex, dir, options, da, bias);
  tex.zero_grad();
  backward(sum(out * Tensor::uniform({24, 16, tex.size(3)}, -1, 1, 40 + view)));
  return {values(out), values(tex.grad()), values(dir.grad()), values(da.grad()), values(bias.grad())};
}

CubeTextureOptions trilinear_on(std::shared_ptr<const raster::RasterBackend> backend) {
  CubeTextureOptions o;
  o.filter = CubeFilter::Trilinear;
  o.backend = std::move(backend);
  return o;
}

// What the device's texture calls did since `before`.
struct Delta {
  std::int64_t uploads, bytes, resident;
};
Delta since(const vulkan::TextureResidency& before) {
  const vulkan::TextureResidency now = vulkan::texture_residency(*shared_gpu());
  return {now.uploads - before.uploads, now.upload_bytes - before.upload_bytes,
          now.resident_calls - before.resident_calls};
}

void check_near_cpu(const View& got, const View& cpu) {
  CHECK(relative_error(got.out, cpu.out) <= 1e-6);
  CHECK(relative_error(got.g_tex, cpu.g_tex) <= 1e-5);
  CHECK(relative_error(got.g_dir, cpu.g_dir) <= 1e-5);
  CHECK(relative_error(got.g_da, cpu.g_da) <= 1e-5);
  CHECK(relative_error(got.g_bias, cpu.g_bias) <= 1e-5);
}

}  // namespace

TEST_CASE("the cube_texture op's forward and adjoint on a Vulkan backend upload the cube map once",
          "[vulkan][cube]") {
  if (!shared_gpu()) return;
  const CubeTextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({6, 16, 16, 3}, -1, 1, 1).set_requires_grad();
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  const View got = render_view(tex, 0, gpu);
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 1);
  // The 6 faces' level 0 alone, 3 floats a texel: the device builds the 4 levels above it.
  CHECK(d.bytes == 6 * 16 * 16 * 3 * std::int64_t(sizeof(float)));
  // The same bits as a fresh backend's call (uploaded: a new tensor), and the CPU op's values.
  Tensor copy = fresh(tex);
  CHECK(render_view(copy, 0, trilinear_on(vulkan::raster_backend(shared_gpu()))) == got);
  Tensor cpu_tex = fresh(tex);
  check_near_cpu(got, render_view(cpu_tex, 0, trilinear_on(nullptr)));
}

TEST_CASE("several views of an unchanged cube map on a Vulkan backend upload it once", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  const CubeTextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({6, 9, 9, 4}, -1, 1, 2).set_requires_grad();
  std::vector<View> views;
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  for (int v = 0; v < 3; ++v) views.push_back(render_view(tex, v, gpu));
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 5);
  for (int v = 0; v < 3; ++v) {
    Tensor copy = fresh(tex);
    CHECK(render_view(copy, v, trilinear_on(vulkan::raster_backend(shared_gpu()))) == views[v]);
  }
}

TEST_CASE("a cube map written in place between calls on a Vulkan backend is uploaded again and its new values used",
          "[vulkan][cube]") {
  if (!shared_gpu()) return;
  const CubeTextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({6, 12, 12, 2}, -1, 1, 3).set_requires_grad();
  const View first = render_view(tex, 0, gpu);
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  float* texels = tex.data<float>();  // an in-place write: the storage's version moves on
  for (std::int64_t i = 0; i < tex.numel(); ++i) texels[i] = 0.5f * texels[i] + 0.25f;
  const View second = render_view(tex, 0, gpu);
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 1);
  CHECK_FALSE(second.out == first.out);
  Tensor copy = fresh(tex);
  CHECK(render_view(copy, 0, trilinear_on(vulkan::raster_backend(shared_gpu()))) == second);
  Tensor cpu_tex = fresh(tex);
  check_near_cpu(second, render_view(cpu_tex, 0, trilinear_on(nullptr)));
}

TEST_CASE("one tensor read as a cube map and as 2D textures on a Vulkan backend keeps a copy of each",
          "[vulkan][cube]") {
  if (!shared_gpu()) return;
  auto backend = vulkan::raster_backend(shared_gpu());
  CubeTextureOptions cube;
  cube.filter = CubeFilter::Bilinear;
  cube.backend = backend;
  TextureOptions plane;
  plane.backend = backend;
  const Tensor tex = Tensor::uniform({6, 8, 8, 2}, -1, 1, 4);
  const Tensor dir = Tensor::uniform({50, 3}, -1, 1, 5), uv = Tensor::uniform({6, 50, 2}, 0, 1, 6);
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  const std::vector<float> first = values(cube_texture(tex, dir, cube));
  const std::vector<float> planes = values(texture(tex, uv, plane));
  const std::vector<float> again = values(cube_texture(tex, dir, cube));
  const Delta d = since(before);
  CHECK(d.uploads == 7);  // the cube map once, each of the 6 2D textures once
  CHECK(d.resident == 1);
  CHECK(again == first);
  cube.backend = plane.backend = nullptr;
  CHECK(relative_error(first, values(cube_texture(tex, dir, cube))) == 0);  // bilinear: the CPU's bits
  CHECK(planes == values(texture(tex, uv, plane)));
}

TEST_CASE("the per-face mip levels a Vulkan device builds from level 0 are the CPU's bit for bit",
          "[vulkan][cube]") {
  if (!shared_gpu()) return;
  // Odd and power-of-two faces (3-wide blocks at odd edges), 1 to 4 channels.
  const int sizes[][2] = {{2, 1}, {5, 3}, {16, 4}, {33, 2}};
  for (const auto& size : sizes) {
    const int S = size[0], C = size[1];
    const raster::MipLayout layout = raster::mip_layout(S, S);
    std::mt19937 rng(S);
    std::uniform_real_distribution<float> value(-1.f, 1.f), lod(-8.f, 8.f);
    const std::int64_t base = std::int64_t(S) * S;
    std::vector<float> faces(6 * base * C), pyramid(6 * (layout.total_texels - base) * C);
    for (float& x : faces) x = value(rng);
    raster::cube_mip_build(faces.data(), C, layout, pyramid.data());
    const std::int64_t N = 3000;
    std::vector<float> dir(3 * N), da(6 * N), grad_out(N * C);
    for (std::int64_t s = 0; s < N; ++s) {
      for (int k = 0; k < 3; ++k) dir[3 * s + k] = value(rng);
      // Footprints from a fraction of a texel to the whole face: every level.
      const float scale = std::exp2(lod(rng)) / S;
      for (int k = 0; k < 6; ++k) da[6 * s + k] = scale * value(rng);
    }
    for (float& g : grad_out) g = value(rng);
    for (const CubeFilter filter : {CubeFilter::Trilinear, CubeFilter::LinearMipmapNearest}) {
      raster::CubeTextureParams<float> p;
      p.faces = faces.data();
      p.layout = layout;
      p.channels = C;
      p.dir = dir.data(), p.dir_da = da.data();
      p.num_samples = N;
      p.filter = filter;
      std::vector<float> out[2], g_faces[2], g_dir[2];
      for (int built = 0; built < 2; ++built) {
        p.pyramid = built ? nullptr : pyramid.data();
        out[built].resize(N * C);
        g_faces[built].assign(faces.size(), 0.f);
        g_dir[built].assign(3 * N, 0.f);
        vulkan::cube_texture_forward(*shared_gpu(), p, out[built].data());
        raster::CubeTextureGrads<float> grads;
        grads.faces = g_faces[built].data();
        grads.dir = g_dir[built].data();
        vulkan::cube_texture_backward(*shared_gpu(), p, grad_out.data(), grads);
      }
      CHECK(out[1] == out[0]);
      CHECK(g_faces[1] == g_faces[0]);
      CHECK(g_dir[1] == g_dir[0]);
    }
  }
}
