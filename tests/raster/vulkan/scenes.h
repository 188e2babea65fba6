// Scenes shared by the GPU tests: float32 clip-space triangle soups (some
// crossing the near plane), pixel-centre grids, slivers, meshes in
// perspective and surfaces cutting through each other; the shared device (null, with a warning saying why, when there
// is none); the CPU kernels' G-buffer; random inputs and the error measure the
// GPU is held to.
#pragma once

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "raster/barycentric_gbuffer.h"
#include "raster/mesh.h"
#include "raster/procedural.h"
#include "raster/rasterize.h"
#include "raster/vulkan/device.h"

namespace gr::testing {

using raster::Cull;
using raster::Mesh;
using raster::RasterParams;
using raster::RasterSettings;

inline std::shared_ptr<vulkan::Device> shared_gpu() {
  static std::string why;
  static std::shared_ptr<vulkan::Device> device = vulkan::Device::open(&why);
  if (!device) WARN("no Vulkan device, GPU test skipped: " << why);
  return device;
}

struct Scene {
  std::vector<float> clip;
  std::vector<std::int32_t> tris;
  RasterParams<float> params(int W, int H, Cull cull = Cull::None) const {
    return {clip.data(), static_cast<std::int64_t>(clip.size() / 4), tris.data(),
            static_cast<std::int64_t>(tris.size() / 3), RasterSettings{W, H, cull}};
  }
};

// Random triangles: vertices anywhere around the view, w in [-0.5, 2] (some
// behind the camera, so triangles cross the near plane), z beyond [-w, w] too.
inline Scene random_soup(int triangles, unsigned seed, double spread = 1.3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-spread, spread), zz(-1.3, 1.3), ww(-0.5, 2.0), jitter(-0.15, 0.15);
  Scene s;
  for (int t = 0; t < triangles; ++t) {
    const double cx = xy(rng), cy = xy(rng), cz = zz(rng), cw = ww(rng);
    for (int k = 0; k < 3; ++k) {
      const double w = cw + 0.3 * jitter(rng);
      s.clip.insert(s.clip.end(), {float((cx + jitter(rng)) * std::abs(w)), float((cy + jitter(rng)) * std::abs(w)),
                                   float((cz + jitter(rng)) * w), float(w)});
      s.tris.push_back(3 * t + k);
    }
  }
  return s;
}

// A grid of n x n quads whose vertices lie on pixel centres of a W x W image
// (every diagonal passes through centres): the tie rule decides most pixels.
inline Scene pixel_centre_grid(int W, int n) {
  Scene s;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double px = 0.5 + (W - 1.0) * i / n, py = 0.5 + (W - 1.0) * j / n;
      s.clip.insert(s.clip.end(), {float(2.0 * px / W - 1.0), float(1.0 - 2.0 * py / W), 0.25f, 1.0f});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      s.tris.insert(s.tris.end(), {a, b, d, a, d, c});
    }
  return s;
}

// Slivers: needles a few pixels wide or less across the view, at random
// depths and w (some crossing the near plane), and fans of nearly collinear
// triangles sharing a vertex.
inline Scene slivers(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-1.2, 1.2), zz(-0.9, 0.9), ww(-0.3, 2.0), thin(1e-4, 2e-2);
  Scene s;
  for (int t = 0; t < count; ++t) {
    const double ax = xy(rng), ay = xy(rng), bx = xy(rng), by = xy(rng), d = thin(rng);
    const double w[3] = {ww(rng), ww(rng), ww(rng)};
    const double x[3] = {ax, bx, 0.5 * (ax + bx) + d}, y[3] = {ay, by, 0.5 * (ay + by) - d};
    for (int k = 0; k < 3; ++k) {
      const double wk = std::abs(w[k]) < 0.05 ? 0.05 : w[k];
      s.clip.insert(s.clip.end(), {float(x[k] * std::abs(wk)), float(y[k] * std::abs(wk)), float(zz(rng) * wk), float(wk)});
      s.tris.push_back(3 * t + k);
    }
  }
  return s;
}

// A mesh in perspective: positions scaled and moved `distance` in front of
// the camera (w = distance - z), so that a small distance puts part of it behind.
inline Scene perspective(const Mesh& m, double scale, double distance) {
  Scene s;
  const float* p = m.positions.data<float>();
  for (std::int64_t i = 0; i < m.num_vertices(); ++i) {
    const double x = scale * p[3 * i], y = scale * p[3 * i + 1], z = scale * p[3 * i + 2];
    const double w = distance - z;
    s.clip.insert(s.clip.end(), {float(1.2 * x), float(1.2 * y), float(1.02 * w - 0.2), float(w)});
  }
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  s.tris.assign(t, t + 3 * m.num_triangles());
  return s;
}

// Two triangles cutting through each other (tests/ops/render/test_visibility_antialias.cpp's
// crossing_clip): one at depth 0, one tilted, their line mostly along x or y.
inline Scene crossing_pair(bool along_x) {
  Scene s;
  s.clip = along_x ? std::vector<float>{-0.9f, -0.8f, 0.0f,  1.0f,  0.85f, -0.7f, 0.0f,   1.2f,
                                        0.1f,  0.9f,  0.0f,  0.9f,  -0.8f, 0.85f, -0.5f,  1.1f,
                                        0.83f, 0.6f,  -0.35f, 1.0f, 0.05f, -0.9f, 0.62f,  1.15f}
                   : std::vector<float>{-0.9f,  -0.8f,  0.0f,   1.0f,  0.85f, -0.7f, 0.0f, 1.2f,
                                        0.1f,   0.9f,   0.0f,   0.9f,  -0.85f, 0.8f, -0.55f, 1.1f,
                                        -0.7f,  -0.85f, -0.4f,  1.0f,  0.9f,  0.05f, 0.6f, 1.15f};
  s.tris = {0, 1, 2, 3, 4, 5};
  return s;
}

// Large triangles at random depths in [-0.6, 0.6] and w in [0.8, 1.3]: they
// cut through each other everywhere.
inline Scene interpenetrating(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Scene s;
  for (int i = 0; i < 3 * count; ++i) {
    const double w = 0.8 + 0.5 * u(rng);
    s.clip.insert(s.clip.end(), {float((1.8 * u(rng) - 0.9) * w), float((1.8 * u(rng) - 0.9) * w),
                                 float((1.2 * u(rng) - 0.6) * w), float(w)});
    s.tris.push_back(i);
  }
  return s;
}

// Two icospheres, the smaller one moved partly into the larger (as
// tests/ops/render/test_visibility_antialias.cpp's spheres), in perspective;
// unshared: every triangle with its own three vertices (only a welded
// topology closes them).
inline Scene two_spheres(bool unshared) {
  Mesh small = raster::make_icosphere(2, 0.6f);
  float* p = small.positions.data<float>();
  for (std::int64_t i = 0; i < small.num_vertices(); ++i) p[3 * i] += 0.55f, p[3 * i + 1] += 0.2f, p[3 * i + 2] += 0.3f;
  const Scene a = perspective(raster::make_icosphere(2, 0.8f), 1.5, 3.5), b = perspective(small, 1.5, 3.5);
  Scene s = a;
  const std::int32_t na = static_cast<std::int32_t>(a.clip.size() / 4);
  s.clip.insert(s.clip.end(), b.clip.begin(), b.clip.end());
  for (std::int32_t t : b.tris) s.tris.push_back(t + na);
  if (!unshared) return s;
  Scene u;
  for (std::int32_t t : s.tris) {
    u.clip.insert(u.clip.end(), s.clip.begin() + 4 * t, s.clip.begin() + 4 * t + 4);
    u.tris.push_back(static_cast<std::int32_t>(u.tris.size()));
  }
  return u;
}

// The CPU kernels' G-buffer of a scene: the coverage of raster::rasterize_forward,
// then raster::barycentric_gbuffer_forward's rast (H*W*4) and, with
// derivatives, db (H*W*4); y_up as RasterSettings::y_up.
struct CpuGBuffer {
  std::vector<std::int32_t> id;
  std::vector<float> rast, db;
};
inline raster::BarycentricGBufferParams<float> gbuffer_params(const Scene& s, int W, int H, bool y_up) {
  raster::BarycentricGBufferParams<float> p;
  p.clip = s.clip.data();
  p.num_vertices = static_cast<std::int64_t>(s.clip.size() / 4);
  p.tris = s.tris.data();
  p.num_tris = static_cast<std::int64_t>(s.tris.size() / 3);
  p.width = W;
  p.height = H;
  p.y_up = y_up;
  return p;
}
inline CpuGBuffer cpu_gbuffer(const Scene& s, int W, int H, bool y_up = false, bool derivatives = false) {
  const std::size_t px = static_cast<std::size_t>(W) * H;
  CpuGBuffer g{std::vector<std::int32_t>(px), std::vector<float>(4 * px), std::vector<float>(derivatives ? 4 * px : 0)};
  std::vector<float> uv(2 * px), depth(px);
  RasterParams<float> p = s.params(W, H);
  p.settings.y_up = y_up;
  raster::rasterize_forward(p, g.id.data(), uv.data(), depth.data());
  raster::barycentric_gbuffer_forward(gbuffer_params(s, W, H, y_up), g.id.data(), 0, g.rast.data(),
                                      derivatives ? g.db.data() : nullptr);
  return g;
}

// n values uniform in [-1, 1).
inline std::vector<float> random_values(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-1.f, 1.f);
  std::vector<float> v(n);
  for (float& x : v) x = d(rng);
  return v;
}

// max |a - b| / max |b| (0 when both are all zeros).
inline double relative_error(const std::vector<float>& a, const std::vector<float>& b) {
  double diff = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff = std::max(diff, std::abs(double(a[i]) - double(b[i])));
    scale = std::max(scale, std::abs(double(b[i])));
  }
  return scale > 0.0 ? diff / scale : diff;
}

// max |a - b| / max(|b|, 1e-30) elementwise: the largest relative error of any value.
inline double elementwise_error(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(double(a[i]) - double(b[i])) / std::max(std::abs(double(b[i])), 1e-30));
  return worst;
}

}  // namespace gr::testing
