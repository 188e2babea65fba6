// The texture op (ops/render/texture.h) on a Vulkan backend, forward and
// backward, as a fit's iteration runs it: 512 x 512 trilinear samples from a
// 2048 x 2048 x 3 float32 texture with its 12-level mip chain,
// gradients to the texture, uv, uv_dx and uv_dy. Prints, per iteration:
// the wall time (median of the runs, ms) and the texels the device uploaded
// (calls, MB: vulkan::texture_residency), for two loops: `unchanged` (the
// same texture every iteration) and `written` (the texture written in place
// before each iteration, as an optimizer step does).
// Usage: bench_gpu_texture_op [iterations=7]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <utility>
#include <vector>

#include "ops/ops.h"
#include "raster/mipmap.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/texture.h"

using namespace gr;

// The calling thread's CPU time, ms (its staging copies and host work; lavapipe runs on its own threads).
double thread_ms() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

int main(int argc, char** argv) {
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 7;
  std::string why;
  const std::shared_ptr<vulkan::Device> device = vulkan::Device::open(&why);
  if (!device) {
    std::printf("no Vulkan device: %s\n", why.c_str());
    return 0;
  }
  TextureOptions options;
  options.filter = Filter::Trilinear;
  options.backend = vulkan::raster_backend(device);
  Tensor tex = Tensor::uniform({2048, 2048, 3}, -1, 1, 1).set_requires_grad();
  Tensor uv = Tensor::uniform({512, 512, 2}, 0, 1, 2).set_requires_grad();
  Tensor dx = Tensor::uniform({512, 512, 2}, -0.004, 0.004, 3).set_requires_grad();
  Tensor dy = Tensor::uniform({512, 512, 2}, -0.004, 0.004, 4).set_requires_grad();
  const Tensor w = Tensor::uniform({512, 512, 3}, -1, 1, 5);
  // The forward alone, the levels uploaded (CPU's mip_build) or built on the
  // device: its upload pass (device timestamps: the copies, and the mip passes).
  if (argc > 2) {
    const raster::MipLayout layout = raster::mip_layout(2048, 2048);
    std::vector<float> pyramid((layout.total_texels - 2048 * 2048) * 3), out(512 * 512 * 3);
    raster::mip_build(std::as_const(tex).data<float>(), 3, layout, pyramid.data());
    raster::TextureParams<float> p;
    p.tex = std::as_const(tex).data<float>();
    p.layout = layout;
    p.channels = 3;
    p.uv = std::as_const(uv).data<float>(), p.uv_dx = std::as_const(dx).data<float>();
    p.uv_dy = std::as_const(dy).data<float>();
    p.num_samples = 512 * 512;
    p.filter = Filter::Trilinear;
    for (int round = 0; round < 4; ++round)
      for (const bool built : {false, true}) {
        p.pyramid = built ? nullptr : pyramid.data();
        const vulkan::GpuTimes t = vulkan::texture_forward(*device, p, out.data());
        std::printf("forward, levels %s: upload pass %.1f ms, sampling %.1f ms\n", built ? "built" : "uploaded",
                    t.upload_ms, t.kernels_ms);
      }
    return 0;
  }
  for (const bool written : {false, true}) {
    std::vector<double> ms, cpu;
    const vulkan::TextureResidency before = vulkan::texture_residency(*device);
    for (int i = 0; i <= iterations; ++i) {  // iteration 0: warm-up (shaders, buffers), not timed
      if (written) {
        float* t = tex.data<float>();  // an in-place write: the storage's version moves on
        t[i % tex.numel()] += 1e-3f;
      }
      const auto start = std::chrono::steady_clock::now();
      const double cpu_start = thread_ms();
      tex.zero_grad();
      backward(sum(texture(tex, uv, options, dx, dy) * w));
      if (i > 0) cpu.push_back(thread_ms() - cpu_start);
      if (i > 0) ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    const vulkan::TextureResidency after = vulkan::texture_residency(*device);
    std::sort(ms.begin(), ms.end());
    std::sort(cpu.begin(), cpu.end());
    const double n = iterations + 1;
    std::printf("%-9s median %.1f ms (min %.1f, max %.1f), calling thread CPU %.1f ms, over %d iterations; per iteration %.2f uploads, %.1f MB\n",
                written ? "written" : "unchanged", ms[ms.size() / 2], ms.front(), ms.back(), cpu[cpu.size() / 2], iterations,
                (after.uploads - before.uploads) / n, (after.upload_bytes - before.upload_bytes) / n / 1e6);
  }
}
