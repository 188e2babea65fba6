// Fragment compaction and row kernels (raster/fragments.h) against serial references.
#include <catch2/catch.hpp>

#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/fragments.h"

using namespace gr;

TEST_CASE("fragment kernels: compaction equals a serial filter for any size and thread count", "[raster][fragments]") {
  std::mt19937 rng(3);
  for (std::int64_t pixels : {std::int64_t(1), std::int64_t(777), std::int64_t(16384), std::int64_t(100003)}) {
    for (double density : {0.0, 0.3, 1.0}) {
      std::vector<std::int32_t> id(static_cast<std::size_t>(pixels));
      std::bernoulli_distribution covered(density);
      for (auto& v : id) v = covered(rng) ? 1 + static_cast<std::int32_t>(rng() % 50) : 0;
      std::vector<std::int32_t> want_index, want_id;
      for (std::int64_t p = 0; p < pixels; ++p)
        if (id[p] != 0) {
          want_index.push_back(static_cast<std::int32_t>(p));
          want_id.push_back(id[p]);
        }
      for (int threads : {1, 2}) {
        INFO("pixels " << pixels << " density " << density << " threads " << threads);
        set_num_threads(threads);
        const raster::FragmentPlan plan = raster::plan_fragments(id.data(), pixels);
        REQUIRE(plan.count() == static_cast<std::int64_t>(want_index.size()));
        std::vector<std::int32_t> index(want_index.size()), tri(want_index.size());
        raster::compact_fragments(id.data(), pixels, plan, index.data(), tri.data());
        CHECK(index == want_index);
        CHECK(tri == want_id);
      }
      set_num_threads(0);
    }
  }
}

TEST_CASE("fragment kernels: gather, scatter and the uncovered sum agree with serial loops", "[raster][fragments]") {
  const std::int64_t pixels = 40000, C = 3;
  std::vector<std::int32_t> index;
  for (std::int64_t p = 0; p < pixels; p += 1 + p % 7) index.push_back(static_cast<std::int32_t>(p));
  const std::int64_t n = static_cast<std::int64_t>(index.size());
  std::vector<double> image(static_cast<std::size_t>(pixels * C));
  for (std::size_t i = 0; i < image.size(); ++i) image[i] = 0.001 * static_cast<double>(i % 1000) - 0.3;
  std::vector<double> rows(static_cast<std::size_t>(n * C));
  raster::gather_fragment_rows(image.data(), index.data(), n, C, rows.data());
  for (std::int64_t f = 0; f < n; ++f)
    for (std::int64_t c = 0; c < C; ++c) REQUIRE(rows[f * C + c] == image[index[f] * C + c]);
  std::vector<double> back(image.size(), -1.0);
  raster::scatter_fragment_rows(rows.data(), index.data(), n, C, back.data());
  std::vector<bool> is_frag(static_cast<std::size_t>(pixels), false);
  for (auto p : index) is_frag[p] = true;
  double want[3] = {0, 0, 0};
  for (std::int64_t p = 0; p < pixels; ++p)
    for (std::int64_t c = 0; c < C; ++c) {
      REQUIRE(back[p * C + c] == (is_frag[p] ? image[p * C + c] : -1.0));
      if (!is_frag[p]) want[c] += image[p * C + c];
    }
  double sum[3];
  raster::sum_uncovered(image.data(), pixels, C, index.data(), n, sum);
  for (int c = 0; c < 3; ++c) CHECK(sum[c] == Approx(want[c]).epsilon(1e-12));
}
