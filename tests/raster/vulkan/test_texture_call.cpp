// raster/vulkan/texture_call.cpp on its own: a TextureCall built by hand (one
// bilinear 2D lookup per sample, as the shaders see it) gives the CPU
// kernel's samples and texel and uv gradients; the texels it reads stay on the
// device between calls that name their copy (KeptTexels), and a call whose
// texels differ in size does not read another call's copy.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <vector>

#include "raster/mipmap.h"
#include "raster/texture.h"
#include "raster/vulkan/internal/texture_call.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::testing;

namespace {

struct Lookups {
  int width = 0, height = 0, channels = 0;
  std::vector<float> tex, uv;
  std::int64_t samples() const { return static_cast<std::int64_t>(uv.size() / 2); }
};

Lookups random_lookups(int width, int height, int channels, int samples, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(-1.0f, 1.0f), coord(-0.25f, 1.25f);
  Lookups l{width, height, channels, {}, {}};
  l.tex.resize(static_cast<std::size_t>(width) * height * channels);
  for (float& t : l.tex) t = value(rng);
  l.uv.resize(2 * static_cast<std::size_t>(samples));
  for (float& c : l.uv) c = coord(rng);
  return l;
}

// The CPU kernel's view of the same lookups (bilinear, repeat).
raster::TextureParams<float> cpu_params(const Lookups& l) {
  raster::TextureParams<float> p;
  p.tex = l.tex.data();
  p.layout = raster::mip_layout(l.height, l.width, 0);
  p.channels = l.channels;
  p.uv = l.uv.data();
  p.num_samples = l.samples();
  p.filter = raster::Filter::Bilinear;
  p.wrap = raster::Wrap::Repeat;
  return p;
}

// The shaders' view, written out: level 0 only, one face, uv the only sample input.
vulkan::TextureCall bilinear_call(const Lookups& l) {
  vulkan::TextureCall c;
  c.base_texels = c.face_texels = std::int64_t(l.width) * l.height;
  c.texels = {{l.tex.data(), l.tex.size() * sizeof(float)}};
  c.levels = {l.height, l.width, 0, 0};
  c.uv = {l.uv.data(), l.uv.size() * sizeof(float)};
  const auto n = static_cast<std::int32_t>(l.samples());
  c.push = {n, l.channels, 1, vulkan::kShaderBilinear, static_cast<std::int32_t>(raster::Wrap::Repeat), 0, 0, 4 * n};
  c.sample_grads = 7;  // texture.cpp's kSampleGrads: the uv gradient first
  return c;
}

}  // namespace

TEST_CASE("a texture call built by hand gives the CPU kernel's samples and gradients", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  vulkan::Device& device = *shared_gpu();
  const Lookups l = random_lookups(13, 7, 3, 200, 5);
  const raster::TextureParams<float> p = cpu_params(l);
  const std::size_t out_size = static_cast<std::size_t>(l.samples() * l.channels);

  std::vector<float> gpu(out_size), cpu(out_size);
  vulkan::run_texture_forward(device, bilinear_call(l), gpu.data());
  raster::texture_forward(p, cpu.data());
  CHECK(relative_error(gpu, cpu) <= 1e-6);

  std::vector<float> grad_out(out_size);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> g(-1.0f, 1.0f);
  for (float& x : grad_out) x = g(rng);
  std::vector<float> cpu_tex(l.tex.size(), 0.0f), cpu_uv(l.uv.size(), 0.0f);
  raster::TextureGrads<float> grads;
  grads.tex = cpu_tex.data();
  grads.uv = cpu_uv.data();
  raster::texture_backward(p, grad_out.data(), grads);

  std::vector<float> gpu_tex(l.tex.size(), 0.0f), gpu_uv(l.uv.size(), 0.0f);
  vulkan::run_texture_backward(device, bilinear_call(l), grad_out.data(), true, true,
                               [&](const float* per_sample, const float* texels) {
                                 REQUIRE(per_sample);
                                 REQUIRE(texels);
                                 for (std::int64_t i = 0; i < l.samples(); ++i) {
                                   gpu_uv[2 * i] = per_sample[7 * i];
                                   gpu_uv[2 * i + 1] = per_sample[7 * i + 1];
                                 }
                                 vulkan::add_to(gpu_tex.data(), texels, static_cast<std::int64_t>(gpu_tex.size()));
                               });
  CHECK(relative_error(gpu_tex, cpu_tex) <= 1e-5);
  CHECK(relative_error(gpu_uv, cpu_uv) <= 1e-5);
}

TEST_CASE("a texture call's kept texels are read again only by a call of the same size", "[vulkan][texture]") {
  if (!shared_gpu()) return;
  // A device of its own: the residency counts are this test's alone.
  std::string why;
  const std::shared_ptr<vulkan::Device> device = vulkan::Device::open(&why);
  REQUIRE(device);
  const Lookups small = random_lookups(8, 8, 2, 50, 1), large = random_lookups(16, 8, 2, 50, 2);
  std::vector<float> first(100), again(100), other(100);

  vulkan::KeptTexels kept;
  vulkan::run_texture_forward(*device, bilinear_call(small), first.data(), &kept);
  REQUIRE(kept.serial != 0);
  vulkan::run_texture_forward(*device, bilinear_call(small), again.data(), &kept);
  vulkan::TextureResidency r = vulkan::texture_residency(*device);
  CHECK(r.uploads == 1);
  CHECK(r.resident_calls == 1);
  CHECK(r.upload_bytes == static_cast<std::int64_t>(small.tex.size() * sizeof(float)));
  CHECK(std::memcmp(first.data(), again.data(), first.size() * sizeof(float)) == 0);

  // The small texture's copy named, but another size of texels: uploaded.
  vulkan::run_texture_forward(*device, bilinear_call(large), other.data(), &kept);
  r = vulkan::texture_residency(*device);
  CHECK(r.uploads == 2);
  CHECK(r.resident_calls == 1);
  std::vector<float> cpu(100);
  raster::texture_forward(cpu_params(large), cpu.data());
  CHECK(relative_error(other, cpu) <= 1e-6);

  // Without a KeptTexels the call uploads and keeps nothing.
  const int kept_before = vulkan::texture_residency(*device).kept;
  vulkan::run_texture_forward(*device, bilinear_call(small), again.data());
  r = vulkan::texture_residency(*device);
  CHECK(r.uploads == 3);
  CHECK(r.kept == kept_before);
}

TEST_CASE("add_to adds into the destination and skips a missing one", "[vulkan][texture]") {
  std::vector<float> dst = {1.0f, 2.0f, 3.0f};
  const std::vector<float> src = {0.5f, -2.0f, 4.0f};
  vulkan::add_to(dst.data(), src.data(), 3);
  CHECK(dst == std::vector<float>{1.5f, 0.0f, 7.0f});
  vulkan::add_to(nullptr, src.data(), 3);  // no gradient wanted: nothing written
}
