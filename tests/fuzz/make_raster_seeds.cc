// Writes the raster seed corpus (tests/fuzz/corpus/raster), including the
// reproducers of fixed fuzz findings, with encode_raster_case. Built with -DGRADRASTER_FUZZ=ON; run
// as  build-san/fuzz/fuzz_make_raster_seeds tests/fuzz/corpus
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "fuzz/fuzz_targets.h"

using gr::fuzz::RasterCase;

namespace {

RasterCase two_triangles() {
  RasterCase c;
  c.width = 12, c.height = 10, c.channels = 3;
  c.clip = {-0.9, -0.8, 0.1, 1.0, 0.9, -0.7, 0.2, 2.0, -0.2, 0.9, 0.3, 0.7,
            0.2,  0.1,  -0.1, 1.5, 0.95, 0.9, 0.0, 1.1, -0.6, 0.5, 0.2, 0.8};
  c.triangles = {0, 1, 2, 3, 4, 5};
  for (int i = 0; i < 18; ++i) c.attributes.push_back(0.1 * i - 0.7);
  c.background_values = {0.5, -1, 2};
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUTPUT_DIR\n", argv[0]);
    return 2;
  }
  std::vector<std::pair<std::string, RasterCase>> cases;
  cases.emplace_back("two_triangles_f32", two_triangles());
  {
    RasterCase c = two_triangles();
    c.float64 = true, c.linear = true, c.background = true, c.cull = 1;
    cases.emplace_back("two_triangles_f64_linear_cull_back", c);
  }
  {
    RasterCase c = two_triangles();
    c.with_derivatives = true, c.cull = 2;
    cases.emplace_back("two_triangles_derivatives_cull_front", c);
  }
  {
    RasterCase c = two_triangles();  // vertex 0 behind the camera: near clipping
    c.clip[2] = -2.0, c.clip[3] = -0.5;
    c.with_derivatives = true;
    cases.emplace_back("near_plane_crossing", c);
  }
  {
    RasterCase c = two_triangles();  // shared vertices, a degenerate (zero-area) triangle
    c.triangles = {0, 1, 2, 2, 1, 0, 0, 0, 1};
    c.float64 = true;
    cases.emplace_back("shared_and_degenerate", c);
  }
  {
    RasterCase c = two_triangles();  // huge and tiny coordinates
    c.clip[0] = 1e30, c.clip[5] = 1e-40, c.clip[7] = 1e-30, c.clip[13] = std::numeric_limits<float>::max();
    cases.emplace_back("huge_and_denormal", c);
  }
  {
    RasterCase c = two_triangles();  // rejected: NaN position, bad index
    c.clip[9] = std::numeric_limits<double>::quiet_NaN();
    c.triangles[4] = 7;
    cases.emplace_back("nan_and_bad_index", c);
  }
  {
    RasterCase c;  // one pixel, one triangle covering it
    c.width = 1, c.height = 1, c.channels = 1;
    c.clip = {-3, -3, 0.5, 1, 3, -3, 0.5, 1, 0, 3, 0.5, 1};
    c.triangles = {0, 1, 2};
    c.attributes = {1, 2, 3};
    c.background_values = {0};
    cases.emplace_back("one_pixel", c);
  }
  {
    RasterCase c;  // fixed finding: a NaN background was accepted, the output was NaN
    c.width = 2, c.height = 2, c.channels = 1, c.background = true;
    c.clip = {-0.9, -0.9, 0, 1, -0.8, -0.9, 0, 1, -0.9, -0.8, 0, 1};  // covers no pixel centre
    c.triangles = {0, 1, 2};
    c.attributes = {1, 2, 3};
    c.background_values = {std::numeric_limits<double>::quiet_NaN()};
    cases.emplace_back("interpolate_accepts_nan_background", c);
  }
  {
    RasterCase c;  // fixed finding: float32 clip gradient overflowed to Inf for w = 1e-39
    c.width = 8, c.height = 8, c.channels = 1;
    c.clip = {0.5e-39, 0.5e-39, 0, 1e-39, -0.9, -0.9, 0, 1, 0.9, -0.9, 0, 1};
    c.triangles = {0, 1, 2};
    c.attributes = {0, 0, 0};
    c.background_values = {0};
    cases.emplace_back("rasterize_backward_inf_grad_tiny_w_float32", c);
  }
  const std::string root = argv[1];
  for (const auto& [name, c] : cases) {
    const std::vector<std::uint8_t> bytes = gr::fuzz::encode_raster_case(c);
    std::ofstream out(root + "/raster/" + name + ".bin", std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out) {
      std::fprintf(stderr, "cannot write %s/raster/%s.bin\n", root.c_str(), name.c_str());
      return 1;
    }
  }
  return 0;
}
