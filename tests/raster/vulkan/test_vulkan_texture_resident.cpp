// The texture op on a Vulkan backend keeps its texture on the device
// (raster/vulkan/texture.h's KeptTexels, ops/render/resident_texture.h):
// the forward and adjoint of one call upload it once, so do several calls on
// an unchanged texture; a texture written in place is uploaded again and its
// new values used; a copy let go (more textures than the device keeps) is
// uploaded again; two threads. And the mip levels the device builds from
// level 0 (texture_mip.comp) are mip_build's: the lookups and gradients
// with them are those with the CPU's levels uploaded, bit for bit. Every result is compared bit for bit with the
// same lookups on a fresh backend and device call (uploaded), and with the
// CPU op within issue 33's tolerances.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "ops/ops.h"
#include "raster/mipmap.h"
#include "raster/texture.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/scenes.h"
#include "raster/vulkan/texture.h"

using namespace gr;
using namespace gr::testing;

namespace {

std::vector<float> values(const Tensor& t) {
  const Tensor& c = t;
  return std::vector<float>(c.data<float>(), c.data<float>() + c.numel());
}

// A new leaf with t's values (another storage).
Tensor fresh(const Tensor& t) {
  const std::vector<float> v = values(t);
  return Tensor::from_values(std::vector<double>(v.begin(), v.end()), t.shape()).set_requires_grad();
}

// One view's trilinear lookups of tex (seeded by view) and their gradients.
struct View {
  std::vector<float> out, g_tex, g_uv, g_dx;
  bool operator==(const View& o) const { return out == o.out && g_tex == o.g_tex && g_uv == o.g_uv && g_dx == o.g_dx; }
};

View render_view(Tensor tex, int view, const TextureOptions& options) {
  Tensor uv = Tensor::uniform({24, 16, 2}, -0.5, 1.5, 10 + view).set_requires_grad();
  Tensor dx = Tensor::uniform({24, 16, 2}, -0.3, 0.3, 20 + view).set_requires_grad();
  Tensor dy = Tensor::uniform({24, 16, 2}, -0.3, 0.3, 30 + view);
  Tensor out = texture(tex, uv, options, dx, dy);
  tex.zero_grad();
  backward(sum(out * Tensor::uniform({24, 16, tex.size(2)}, -1, 1, 40 + view)));
  return {values(out), values(tex.grad()), values(uv.grad()), values(dx.grad())};
}

TextureOptions trilinear_on(std::shared_ptr<const raster::RasterBackend> backend) {
  TextureOptions o;
  o.filter = Filter::Trilinear;
  o.wrap = Wrap::Repeat;
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

}  // namespace

TEST_CASE("the texture op's forward and adjoint on a Vulkan backend upload the texture once", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  const TextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({37, 50, 3}, -1, 1, 1).set_requires_grad();
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  const View got = render_view(tex, 0, gpu);
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 1);
  // Level 0 alone, 3 floats a texel: the device builds the 5 levels above it.
  CHECK(d.bytes == 37 * 50 * 3 * std::int64_t(sizeof(float)));
  // The same bits as a fresh backend's call (uploaded: a new tensor), and the CPU op's values.
  Tensor copy = fresh(tex);
  CHECK(render_view(copy, 0, trilinear_on(vulkan::raster_backend(shared_gpu()))) == got);
  Tensor cpu_tex = fresh(tex);
  const View cpu = render_view(cpu_tex, 0, trilinear_on(nullptr));
  CHECK(relative_error(got.out, cpu.out) <= 1e-6);
  CHECK(relative_error(got.g_tex, cpu.g_tex) <= 1e-5);
  CHECK(relative_error(got.g_uv, cpu.g_uv) <= 1e-5);
  CHECK(relative_error(got.g_dx, cpu.g_dx) <= 1e-5);
}

TEST_CASE("several views of an unchanged texture on a Vulkan backend upload it once", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  const TextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({32, 32, 4}, -1, 1, 2).set_requires_grad();
  std::vector<View> views;
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  for (int v = 0; v < 5; ++v) views.push_back(render_view(tex, v, gpu));
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 9);
  // Each view's bits are those of a fresh backend (uploading).
  for (int v = 0; v < 5; ++v) {
    Tensor copy = fresh(tex);
    CHECK(render_view(copy, v, trilinear_on(vulkan::raster_backend(shared_gpu()))) == views[v]);
  }
}

TEST_CASE("a texture written in place between calls on a Vulkan backend is uploaded again and its new values used",
          "[vulkan][texture]") {
  if (!shared_gpu()) return;
  const TextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor tex = Tensor::uniform({20, 30, 2}, -1, 1, 3).set_requires_grad();
  const View first = render_view(tex, 0, gpu);
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  float* texels = tex.data<float>();  // an in-place write: the storage's version moves on
  for (std::int64_t i = 0; i < tex.numel(); ++i) texels[i] = 0.5f * texels[i] + 0.25f;
  const View second = render_view(tex, 0, gpu);
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 1);
  CHECK_FALSE(second.out == first.out);
  Tensor cpu_tex = fresh(tex);
  const View cpu = render_view(cpu_tex, 0, trilinear_on(nullptr));
  CHECK(relative_error(second.out, cpu.out) <= 1e-6);
  CHECK(relative_error(second.g_uv, cpu.g_uv) <= 1e-5);
}

TEST_CASE("a texture copy the device let go is uploaded again with the same results", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  const TextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  std::vector<Tensor> textures;
  for (int t = 0; t <= vulkan::kKeptTextures; ++t)
    textures.push_back(Tensor::uniform({16, 24, 3}, -1, 1, 100 + t).set_requires_grad());
  const View first = render_view(textures[0], 0, gpu);
  for (int t = 1; t <= vulkan::kKeptTextures; ++t) render_view(textures[t], 0, gpu);
  // kKeptTextures others since: the first's copy went (least recently used).
  const vulkan::TextureResidency before = vulkan::texture_residency(*shared_gpu());
  CHECK(before.kept == vulkan::kKeptTextures);
  CHECK(render_view(textures[0], 0, gpu) == first);
  const Delta d = since(before);
  CHECK(d.uploads == 1);
  CHECK(d.resident == 1);
}

TEST_CASE("two threads texturing on one Vulkan backend get the single-threaded bits", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  const TextureOptions gpu = trilinear_on(vulkan::raster_backend(shared_gpu()));
  Tensor shared_tex = Tensor::uniform({40, 28, 3}, -1, 1, 4).set_requires_grad();
  Tensor own[2] = {Tensor::uniform({40, 28, 3}, -1, 1, 5).set_requires_grad(),
                   Tensor::uniform({40, 28, 3}, -1, 1, 6).set_requires_grad()};
  std::vector<View> want[2];
  for (int k = 0; k < 2; ++k) {
    Tensor a = fresh(own[k]);
    for (int v = 0; v < 4; ++v) want[k].push_back(render_view(a, v, trilinear_on(nullptr)));
  }
  // The shared texture's views: forward only (its grad is one leaf's).
  auto shared_view = [&](int v, const TextureOptions& options) {
    NoGradGuard no_grad;
    Tensor uv = Tensor::uniform({24, 16, 2}, -0.5, 1.5, 10 + v);
    Tensor dx = Tensor::uniform({24, 16, 2}, -0.3, 0.3, 20 + v), dy = Tensor::uniform({24, 16, 2}, -0.3, 0.3, 30 + v);
    return values(texture(shared_tex, uv, options, dx, dy));
  };
  std::vector<std::vector<float>> want_shared;
  for (int v = 0; v < 4; ++v) want_shared.push_back(shared_view(v, trilinear_on(vulkan::raster_backend(shared_gpu()))));
  std::vector<View> got[2];
  std::vector<std::vector<float>> got_shared[2];
  auto work = [&](int k) {
    for (int v = 0; v < 4; ++v) {
      got[k].push_back(render_view(own[k], v, gpu));
      got_shared[k].push_back(shared_view(v, gpu));
    }
  };
  std::thread one(work, 0), two(work, 1);
  one.join();
  two.join();
  for (int k = 0; k < 2; ++k)
    for (int v = 0; v < 4; ++v) {
      CHECK(relative_error(got[k][v].out, want[k][v].out) <= 1e-6);
      CHECK(relative_error(got[k][v].g_tex, want[k][v].g_tex) <= 1e-5);
      CHECK(got_shared[k][v] == want_shared[v]);
    }
}

TEST_CASE("the mip levels a Vulkan device builds from level 0 are the CPU's bit for bit", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  // Odd, non-power-of-two and thin sizes (3-wide blocks at odd edges), 1 to 4 channels.
  const int sizes[][3] = {{37, 50, 3}, {5, 3, 1}, {1, 9, 2}, {64, 64, 4}, {255, 129, 3}};
  for (const auto& size : sizes) {
    const int H = size[0], W = size[1], C = size[2];
    const raster::MipLayout layout = raster::mip_layout(H, W);
    std::mt19937 rng(H * 1000 + W);
    std::uniform_real_distribution<float> value(-1.f, 1.f), unit(-0.25f, 1.25f), lod(-8.f, 8.f);
    std::vector<float> tex(std::size_t(H) * W * C), pyramid((layout.total_texels - std::int64_t(H) * W) * C);
    for (float& x : tex) x = value(rng);
    raster::mip_build(tex.data(), C, layout, pyramid.data());
    const std::int64_t S = 4000;
    std::vector<float> uv(2 * S), dx(2 * S), dy(2 * S), grad_out(S * C);
    for (std::int64_t s = 0; s < S; ++s) {
      uv[2 * s] = unit(rng), uv[2 * s + 1] = unit(rng);
      // Footprints from a fraction of a texel to the whole texture: every level.
      const float scale = std::exp2(lod(rng)) / std::max(H, W);
      dx[2 * s] = scale, dx[2 * s + 1] = 0.3f * scale * value(rng);
      dy[2 * s] = 0.3f * scale * value(rng), dy[2 * s + 1] = scale;
    }
    for (float& g : grad_out) g = value(rng);
    for (const raster::Filter filter : {raster::Filter::Trilinear, raster::Filter::LinearMipmapNearest}) {
      raster::TextureParams<float> p;
      p.tex = tex.data();
      p.layout = layout;
      p.channels = C;
      p.uv = uv.data(), p.uv_dx = dx.data(), p.uv_dy = dy.data();
      p.num_samples = S;
      p.filter = filter;
      std::vector<float> out[2], g_tex[2], g_uv[2];
      for (int built = 0; built < 2; ++built) {
        p.pyramid = built ? nullptr : pyramid.data();
        out[built].resize(S * C);
        g_tex[built].assign(tex.size(), 0.f);
        g_uv[built].assign(2 * S, 0.f);
        vulkan::texture_forward(*shared_gpu(), p, out[built].data());
        raster::TextureGrads<float> grads;
        grads.tex = g_tex[built].data();
        grads.uv = g_uv[built].data();
        vulkan::texture_backward(*shared_gpu(), p, grad_out.data(), grads);
      }
      CHECK(out[1] == out[0]);
      CHECK(g_tex[1] == g_tex[0]);
      CHECK(g_uv[1] == g_uv[0]);
    }
  }
}
