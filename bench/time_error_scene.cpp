// The time_error scenes: meshes, colours, camera, target poses, and the render
// (gather -> transform -> rasterize -> interpolate over the background ->
// antialias or visibility_antialias -> downsample_box), every step a tape op.
#include "bench/time_error_scene.h"

#include <array>
#include <cmath>
#include <algorithm>
#include <functional>
#include <map>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "ops/render/resample.h"
#include "ops/render/soft_rasterize.h"
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

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// A rigid motion: rotate by angle about axis (through the pivot), then shift.
struct Motion {
  Vec3 axis{0, 1, 0};
  double angle = 0;  // radians
  Vec3 shift{0, 0, 0};
  Vec3 apply(const Vec3& p, const Vec3& pivot = {0, 0, 0}) const {
    if (angle == 0) return {p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]};
    const Vec3 r = rotate({p[0] - pivot[0], p[1] - pivot[1], p[2] - pivot[2]}, axis, angle);
    return {r[0] + pivot[0] + shift[0], r[1] + pivot[1] + shift[1], r[2] + pivot[2] + shift[2]};
  }
  Vec3 apply_direction(const Vec3& n) const { return angle == 0 ? n : rotate(n, axis, angle); }
};

// One object of a scene: a procedural mesh, placed in the world (rest), its
// base colour as a function of the model-space position (Lambert shading at
// the rest pose is baked in by the builder), and its motion to the target pose
// (about its rest position's origin).
struct Part {
  raster::Mesh mesh;
  std::function<Vec3(const Vec3& model_position)> colour;
  Motion rest, target;
  bool inward = false;                          // reverse the winding (normals point inwards)
  std::function<bool(const Vec3&)> keep;        // keep triangles whose model-space centroid passes (all if empty)
};

struct SceneSpec {
  std::string description;
  raster::Cull cull = raster::Cull::None;
  std::vector<Part> parts;
};

// Colour bands of the torus around the ring (period 1/3 turn) and the tube (1/8 turn).
Vec3 torus_colour(const Vec3& p) {
  const double around = std::atan2(p[2], p[0]);
  return {0.55 + 0.4 * std::cos(3 * around), 0.55 + 0.4 * std::cos(3 * around + 2.1),
          0.5 + 0.35 * std::sin(8 * std::atan2(p[1], std::hypot(p[0], p[2]) - 1.0))};
}

// Smooth bands over a sphere around a base colour: longitude (period 1/4
// turn) and latitude, so neighbouring surfaces differ in colour.
std::function<Vec3(const Vec3&)> banded(const Vec3& base) {
  return [base](const Vec3& p) {
    const double lon = std::atan2(p[2], p[0]), lat = std::atan2(p[1], std::hypot(p[0], p[2]));
    return Vec3{base[0] + 0.15 * std::cos(4 * lon), base[1] + 0.15 * std::sin(3 * lat + 0.5),
                base[2] + 0.12 * std::cos(4 * lon + 1.7)};
  };
}

SceneSpec scene_spec(const std::string& name) {
  SceneSpec spec;
  if (name == "torus") {
    // 48 x 24 segments: 2304 triangles, edges of 3-7 px at 128 x 128.
    spec.description = "torus, silhouettes against the background";
    Part torus{raster::make_torus(48, 24, 1.0f, 0.38f), torus_colour, {}, {}};
    torus.target = {normalized({0.3, 1.0, 0.2}), 5 * kPi / 180, {0.05, -0.03, 0.0}};
    spec.parts.push_back(std::move(torus));
  } else if (name == "intersection") {
    // A 2.6-unit square (16 x 16 cells, 512 triangles) tilted about 12 degrees out of
    // the y = 0 plane, and a sphere of radius 0.75 (1280 triangles) sunk to its
    // equator into it; the target lifts and turns the sphere and tilts the
    // square, so the intersection curve changes shape.
    spec.description = "sphere sunk half into a tilted square: intersection curve";
    Part plane{raster::make_plane(16, 16, 2.6f),
               [](const Vec3& p) {
                 return Vec3{0.25 + 0.1 * std::cos(2.4 * p[0]), 0.55 + 0.12 * std::sin(2.0 * p[1] + 0.3), 0.3};
               },
               {normalized({1, 0, 0.3}), -78 * kPi / 180, {0, -0.1, 0}},
               {normalized({1, 0, -0.5}), 3 * kPi / 180, {0.0, 0.0, 0.0}}};
    Part sphere{raster::make_icosphere(3, 0.75f), banded({0.8, 0.45, 0.3}), {{0, 1, 0}, 0, {0.1, -0.1, 0.05}},
                {normalized({0.2, 1, 0.5}), 8 * kPi / 180, {0.05, 0.06, -0.03}}};
    spec.parts.push_back(std::move(plane));
    spec.parts.push_back(std::move(sphere));
  } else if (name == "occlusion") {
    // A sphere of radius 1 (1280 triangles) and, 1.2 units nearer the camera
    // and to the right, one of radius 0.45 (320 triangles) covering part of
    // its right half and its silhouette; each moves on its own in the target.
    spec.description = "small sphere in front of a large one: occlusion";
    Part back{raster::make_icosphere(3, 1.0f), banded({0.35, 0.5, 0.75}), {{0, 1, 0}, 0, {-0.15, -0.1, -0.2}},
              {normalized({0.3, 1, 0.2}), 5 * kPi / 180, {0.03, -0.02, 0.0}}};
    Part front{raster::make_icosphere(2, 0.45f), banded({0.8, 0.7, 0.3}),
               {{0, 1, 0}, 0, {0.5, 0.6, 1.0}},
               {normalized({1, 0.2, 0.4}), 10 * kPi / 180, {-0.06, 0.04, 0.0}}};
    spec.parts.push_back(std::move(back));
    spec.parts.push_back(std::move(front));
  } else if (name == "open_culled") {
    // A UV sphere of radius 1.2 (48 segments, 20 rings of 9 degrees) up to
    // 27 degrees of latitude (13 rings, 1200 triangles): a cup opening upwards, wound outwards and
    // drawn with back faces culled. The outside of the near wall shows, the
    // inside of the far wall (back faces) seen through the opening is culled,
    // and so is the outside of the far wall behind it: the background shows
    // through the opening, bounded by the near rim and by culled edges.
    spec.description = "open bowl, back faces culled";
    spec.cull = raster::Cull::Back;
    Part bowl{raster::make_uv_sphere(20, 48, 1.2f), banded({0.55, 0.6, 0.4}), {{1, 0, 0}, 0, {0, 0.1, 0}},
              {normalized({1, 0.3, 0.2}), 6 * kPi / 180, {0.04, -0.03, 0.0}}};
    bowl.keep = [](const Vec3& c) { return c[1] < 0.55; };  // whole rings: the rim at 27 degrees (y = 0.545)
    spec.parts.push_back(std::move(bowl));
  } else {
    throw ValueError("TimeErrorScene: unknown scene '" + name + "' (torus, intersection, occlusion, open_culled)");
  }
  return spec;
}

}  // namespace

const std::vector<std::string>& time_error_scene_names() {
  static const std::vector<std::string> names{"torus", "intersection", "occlusion", "open_culled"};
  return names;
}

TimeErrorScene::TimeErrorScene(const std::string& name) : name_(name) {
  const SceneSpec spec = scene_spec(name);
  description_ = spec.description;
  cull_ = spec.cull;

  // Weld each part's seam copies (bit-identical positions) into shared points,
  // so the parameters describe surfaces that cannot crack open; parts never
  // share points. The render vertices of all parts are gathered from them.
  std::vector<std::int32_t> index, triangles;
  std::vector<double> points, colours, target;
  std::vector<std::int32_t> point_part;
  const Vec3 light = normalized({0.4, 1.0, 0.6});
  for (std::size_t part = 0; part < spec.parts.size(); ++part) {
    const Part& p = spec.parts[part];
    const std::int64_t n = p.mesh.num_vertices();
    const float* pos = p.mesh.positions.data<float>();
    const float* nrm = p.mesh.normals.data<float>();
    const std::int32_t* tri = p.mesh.triangles.data<std::int32_t>();
    // Keep the triangles that pass, and only the vertices they use.
    std::vector<std::int32_t> kept;
    for (std::int64_t t = 0; t < p.mesh.num_triangles(); ++t) {
      const std::int32_t* abc = tri + 3 * t;
      Vec3 centroid{0, 0, 0};
      for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 3; ++i) centroid[i] += pos[3 * abc[k] + i] / 3.0;
      if (p.keep && !p.keep(centroid)) continue;
      for (int k : {0, p.inward ? 2 : 1, p.inward ? 1 : 2}) kept.push_back(abc[k]);
    }
    std::vector<std::int32_t> render_vertex(static_cast<std::size_t>(n), -1);
    for (std::int32_t v : kept) render_vertex[v] = 0;
    std::map<std::array<float, 3>, std::int32_t> point_of;
    for (std::int64_t v = 0; v < n; ++v) {
      if (render_vertex[v] < 0) continue;
      render_vertex[v] = static_cast<std::int32_t>(index.size());
      const std::array<float, 3> key{pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]};
      auto [it, fresh] = point_of.emplace(key, static_cast<std::int32_t>(points.size() / 3));
      index.push_back(it->second);
      if (!fresh) continue;
      point_part.push_back(static_cast<std::int32_t>(part));
      const Vec3 model{key[0], key[1], key[2]};
      const Vec3 world = p.rest.apply(model);
      for (double x : world) points.push_back(x);
      // Lambert shading at the rest pose baked in (the colours travel with the
      // surface, so the target carries them too).
      Vec3 normal = p.rest.apply_direction({nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]});
      if (p.inward) normal = {-normal[0], -normal[1], -normal[2]};
      const double shade = 0.35 + 0.65 * std::max(0.0, dot(normal, light));
      for (double c : p.colour(model)) colours.push_back(c * shade);
      for (double x : p.target.apply(world, p.rest.shift)) target.push_back(x);
    }
    for (std::int32_t v : kept) triangles.push_back(render_vertex[v]);
  }
  const std::int64_t num_points = static_cast<std::int64_t>(points.size() / 3);
  const std::int64_t n = static_cast<std::int64_t>(index.size());
  points_ = Tensor::from_values(points, {num_points, 3}, DType::Float64);
  colours_ = Tensor::from_values(colours, {num_points, 3}, DType::Float64);
  target_points_ = Tensor::from_values(target, {num_points, 3}, DType::Float64);
  render_index_ = Tensor::from_vector(index, {n});
  point_part_ = Tensor::from_vector(point_part, {num_points});
  num_parts_ = static_cast<int>(spec.parts.size());
  triangles_ = Tensor::from_vector(triangles, {static_cast<std::int64_t>(triangles.size() / 3), 3});
  // Weld the antialias topology by point (not by position: two parts may share a position).
  std::vector<float> point_id(index.begin(), index.end());
  topology_ = antialias_topology(triangles_, Tensor::from_vector(point_id, {n, 1}));

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
    if (cull_ != raster::Cull::None) throw ValueError("TimeErrorScene: soft_rasterize cannot cull (scene " + name_ + ")");
    SoftRasterizeOptions options;
    options.width = w, options.height = h, options.eps = kSoftEps;
    const Tensor image = soft_rasterize(clip, triangles_, vertex_colours(colours), Tensor::scalar(settings.soft_sigma, dt),
                                        Tensor::scalar(kSoftGamma, dt), options, background);
    return s == 1 ? image : downsample_box(image, s);
  }
  RasterizeOptions raster_options;
  raster_options.width = w, raster_options.height = h, raster_options.cull = cull_;
  const GBuffer gb = rasterize(clip, triangles_, raster_options);
  InterpolateOptions interpolation;
  interpolation.background = background;  // a constant: coverage has no gradient
  Tensor image = interpolate(vertex_colours(colours), gb, triangles_, interpolation);
  if (settings.antialias && settings.visibility) {
    VisibilityAntialiasOptions options;
    options.topology = topology_;
    image = visibility_antialias(image, gb, clip, triangles_, options);
  } else if (settings.antialias) {
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
