// PNG encoding of a fit snapshot strip (the main example's 6 views at 256 x 256:
// 772 x 1546 RGB, target | current | difference per row): gradraster's encoder
// (raster/io/png_encoder.h, zlib) against stb_image_write as Debian ships it, side
// by side in one run. The image: shaded spheres on a white background and a
// near-black difference panel, as a snapshot looks.
#include <benchmark/benchmark.h>
#include <stb/stb_image_write.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "raster/io/png_encoder.h"

namespace {

constexpr int kView = 256, kViews = 6, kGutter = 2;
constexpr int kWidth = 3 * kView + 2 * kGutter, kHeight = kViews * kView + (kViews - 1) * kGutter;

std::vector<std::uint8_t> snapshot_like_strip() {
  std::vector<std::uint8_t> image(std::size_t(kWidth) * kHeight * 3, 255);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const int row = y / (kView + kGutter), panel = x / (kView + kGutter);
      const int py = y % (kView + kGutter), px = x % (kView + kGutter);
      if (py >= kView || px >= kView) continue;  // gutter
      const double u = (px + 0.5) / kView * 2 - 1, v = (py + 0.5) / kView * 2 - 1;
      const double r2 = u * u + v * v, radius2 = 0.5 + 0.04 * row + (panel == 1 ? 0.01 : 0);
      std::uint8_t* p = &image[(std::size_t(y) * kWidth + x) * 3];
      if (panel == 2) {  // the difference panel: dark, with a faint ring
        const double ring = std::fabs(std::sqrt(r2) - std::sqrt(radius2)) < 0.01 ? 80 : 0;
        p[0] = p[1] = p[2] = static_cast<std::uint8_t>(ring);
      } else if (r2 < radius2) {  // Lambert shading of a sphere lit from the upper left
        const double nz = std::sqrt(radius2 - r2) / std::sqrt(radius2);
        const double lambert = std::fmax(0.0, 0.3 * -u + 0.3 * -v + 0.9 * nz);
        p[0] = static_cast<std::uint8_t>(40 + 200 * lambert);
        p[1] = static_cast<std::uint8_t>(60 + 150 * lambert);
        p[2] = static_cast<std::uint8_t>(90 + 120 * lambert);
      }
    }
  return image;
}

void BM_png_snapshot_strip_gradraster(benchmark::State& state) {
  const auto image = snapshot_like_strip();
  std::size_t bytes = 0;
  for (auto _ : state) {
    const auto png = gr::raster::encode_png_levels(image.data(), kHeight, kWidth, 3, "bench");
    bytes = png.size();
    benchmark::DoNotOptimize(png.data());
  }
  state.counters["file_bytes"] = static_cast<double>(bytes);
}

void BM_png_snapshot_strip_stb_image_write(benchmark::State& state) {
  const auto image = snapshot_like_strip();
  std::vector<unsigned char> png;
  for (auto _ : state) {
    png.clear();
    stbi_write_png_to_func(
        [](void* out, void* data, int size) {
          auto* buffer = static_cast<std::vector<unsigned char>*>(out);
          buffer->insert(buffer->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
        },
        &png, kWidth, kHeight, 3, image.data(), kWidth * 3);
    benchmark::DoNotOptimize(png.data());
  }
  state.counters["file_bytes"] = static_cast<double>(png.size());
}

BENCHMARK(BM_png_snapshot_strip_gradraster)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_png_snapshot_strip_stb_image_write)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
