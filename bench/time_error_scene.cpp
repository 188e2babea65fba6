// The time_error scene: torus, colours, camera, target pose, and the render
// (gather -> transform -> rasterize -> interpolate over the background ->
// antialias -> downsample_box), every step a tape op.
#include "bench/time_error_scene.h"

#include <array>
#include <cmath>
#include <algorithm>
#include <map>

#include "autodiff/tape.h"
#include "ops/ops.h"
#include "ops/resample.h"
#include "ops/soft_rasterize.h"
#include "raster/procedural.h"

namespace gr::bench {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kFovY = 50 * kPi / 180;
const std::array<double, 3> kEye{0.0, 3.6 * 0.5736, 3.6 * 0.8192};  // 3.6 units away, 35 degrees above the torus plane
const std::array<double, 3> kBackground{0.08, 0.09, 0.12};
// Soft rasterization's depth softmax: temperature gamma and the background's
// depth score eps. The torus' depth scores zs = (1 - z_ndc) / 2 span
// 0.011-0.032, front and back of the tube differ by a few 1e-3, so no single
// pair both hides the back surface and lets the background win just outside
// every silhouette (u_j - u_b = log D_j + (zs_j - eps) / gamma); this pair had
// the smallest image error against the exact image over gamma 1e-4..1e-2,
// eps 0..0.03 at sigma 0.1 and near the smallest at 0.3 (docs/time_error.md).
constexpr double kSoftGamma = 1e-3;
constexpr double kSoftEps = 0.01;

using Vec3 = std::array<double, 3>;

Vec3 normalized(Vec3 v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}

// Rodrigues: p cos(a) + (k x p) sin(a) + k (k . p)(1 - cos(a)), k a unit axis.
Vec3 rotate(const Vec3& p, const Vec3& k, double a) {
  const double c = std::cos(a), s = std::sin(a), kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
  const Vec3 kxp{k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]};
  Vec3 r;
  for (int i = 0; i < 3; ++i) r[i] = p[i] * c + kxp[i] * s + k[i] * kp * (1 - c);
  return r;
}

Tensor vec3(const Vec3& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}, DType::Float64); }

}  // namespace

TimeErrorScene::TimeErrorScene() {
  // 48 x 24 segments: 2304 triangles, edges of 3-7 px at 128 x 128.
  const raster::Mesh torus = raster::make_torus(48, 24, 1.0f, 0.38f);
  const std::int64_t n = torus.num_vertices();
  const float* pos = torus.positions.data<float>();
  const float* nrm = torus.normals.data<float>();

  // Weld the seam copies (bit-identical positions) into shared points, so the
  // parameters describe a closed surface that cannot crack open.
  std::map<std::array<float, 3>, std::int32_t> point_of;
  std::vector<std::int32_t> index(static_cast<std::size_t>(n));
  std::vector<double> points, colours, target;
  const Vec3 light = normalized({0.4, 1.0, 0.6});
  const Vec3 axis = normalized({0.3, 1.0, 0.2});
  const double angle = 5 * kPi / 180;
  const Vec3 shift{0.05, -0.03, 0.0};
  for (std::int64_t v = 0; v < n; ++v) {
    const std::array<float, 3> key{pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]};
    auto [it, fresh] = point_of.emplace(key, static_cast<std::int32_t>(points.size() / 3));
    index[v] = it->second;
    if (!fresh) continue;
    const Vec3 p{key[0], key[1], key[2]};
    for (double x : p) points.push_back(x);
    // Colour bands around the ring and the tube, with Lambert shading baked in
    // (the colours travel with the surface, so the target carries them too).
    const double around = std::atan2(p[2], p[0]);
    const double lambert = std::max(0.0, nrm[3 * v] * light[0] + nrm[3 * v + 1] * light[1] + nrm[3 * v + 2] * light[2]);
    const double shade = 0.35 + 0.65 * lambert;
    const Vec3 base{0.55 + 0.4 * std::cos(3 * around), 0.55 + 0.4 * std::cos(3 * around + 2.1),
                    0.5 + 0.35 * std::sin(8 * std::atan2(p[1], std::hypot(p[0], p[2]) - 1.0))};
    for (double c : base) colours.push_back(c * shade);
    const Vec3 q = rotate(p, axis, angle);
    for (int i = 0; i < 3; ++i) target.push_back(q[i] + shift[i]);
  }
  const std::int64_t num_points = static_cast<std::int64_t>(points.size() / 3);
  points_ = Tensor::from_values(points, {num_points, 3}, DType::Float64);
  colours_ = Tensor::from_values(colours, {num_points, 3}, DType::Float64);
  target_points_ = Tensor::from_values(target, {num_points, 3}, DType::Float64);
  render_index_ = Tensor::from_vector(index, {n});
  triangles_ = torus.triangles;
  topology_ = antialias_topology(triangles_, torus.positions);

  NoGradGuard no_grad;
  const double distance = std::sqrt(kEye[0] * kEye[0] + kEye[1] * kEye[1] + kEye[2] * kEye[2]);
  const Tensor fov = Tensor::from_values({kFovY}, {1}, DType::Float64);
  view_projection_ =
      matmul(perspective(fov, 1.0, 0.1, 10.0), look_at(vec3(kEye), vec3({0, 0, 0}), vec3({0, 1, 0}))).copy();
  pixels_per_unit_ = 0.5 * kSize / (distance * std::tan(kFovY / 2));
}

Tensor TimeErrorScene::render(const Tensor& points, const Tensor& colours, const RenderSettings& settings) const {
  const DType dt = points.dtype();
  const int s = settings.supersample, w = s * kSize, h = s * kSize;
  Tensor background;
  {
    NoGradGuard no_grad;
    background = Tensor::from_values({kBackground[0], kBackground[1], kBackground[2]}, {3}, dt);
  }
  const Tensor clip = clip_positions(points);
  if (settings.soft_sigma > 0) {
    SoftRasterizeOptions options;
    options.width = w, options.height = h, options.eps = kSoftEps;
    const Tensor image = soft_rasterize(clip, triangles_, vertex_colours(colours), Tensor::scalar(settings.soft_sigma, dt),
                                        Tensor::scalar(kSoftGamma, dt), options, background);
    return s == 1 ? image : downsample_box(image, s);
  }
  const GBuffer gb = rasterize(clip, triangles_, {w, h});
  InterpolateOptions interpolation;
  interpolation.background = background;  // a constant: coverage has no gradient
  Tensor image = interpolate(vertex_colours(colours), clip, gb, triangles_, interpolation);
  if (settings.antialias) {
    AntialiasOptions options;
    options.topology = topology_;
    image = antialias(image, gb, clip, triangles_, options);
  }
  return s == 1 ? image : downsample_box(image, s);
}

Tensor TimeErrorScene::clip_positions(const Tensor& points) const {
  Tensor view_projection;
  {
    NoGradGuard no_grad;
    view_projection = points.dtype() == DType::Float64 ? view_projection_ : cast(view_projection_, points.dtype());
  }
  return transform_points(gather(points, render_index_), view_projection);
}

Tensor TimeErrorScene::vertex_colours(const Tensor& colours) const { return gather(colours, render_index_); }

Tensor TimeErrorScene::background() const {
  return Tensor::from_values({kBackground[0], kBackground[1], kBackground[2]}, {3}, DType::Float64);
}

Tensor TimeErrorScene::loss(const Tensor& points, const Tensor& colours, const Tensor& target,
                            const RenderSettings& settings) const {
  return mean(pow(render(points, colours, settings) - target, 2.0));
}

}  // namespace gr::bench
