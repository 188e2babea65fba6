// The sunk-sphere fit: scene, render (rasterize -> interpolate -> antialias or
// visibility_antialias) and the Adam loop over one scalar, the height.
#include "examples/intersection/sunk_sphere.h"

#include <vector>

#include "ops/ops.h"
#include "raster/procedural.h"

namespace gr::intersection_example {
namespace {

constexpr double kRadius = 0.5;

// Floor (a 3 x 3 square in z = 0, 8 x 8 cells) and sphere (icosphere, 3
// subdivisions, centred at the origin): positions [N, 3], a mask [N, 3] that is
// 1 on the sphere's z, flat colours [N, 3], triangles [M, 3].
struct Scene {
  Tensor base, lift, colours, triangles;
  AntialiasTopology topology;
};

Scene make_scene() {
  const raster::Mesh floor = raster::make_plane(8, 8, 3.0f);
  const raster::Mesh sphere = raster::make_icosphere(3, float(kRadius));
  const std::int64_t nf = floor.num_vertices(), ns = sphere.num_vertices();
  std::vector<double> base, lift, colours;
  for (double x : floor.positions.to_vector()) base.push_back(x);
  for (double x : sphere.positions.to_vector()) base.push_back(x);
  for (std::int64_t i = 0; i < nf + ns; ++i) {
    const bool on_sphere = i >= nf;
    for (double x : {0.0, 0.0, on_sphere ? 1.0 : 0.0}) lift.push_back(x);
    for (double c : on_sphere ? std::vector<double>{0.9, 0.5, 0.2} : std::vector<double>{0.3, 0.6, 0.35})
      colours.push_back(c);
  }
  std::vector<std::int32_t> tris;
  for (double t : floor.triangles.to_vector()) tris.push_back(static_cast<std::int32_t>(t));
  for (double t : sphere.triangles.to_vector()) tris.push_back(static_cast<std::int32_t>(t + nf));
  Scene s;
  s.base = Tensor::from_values(base, {nf + ns, 3}, DType::Float64);
  s.lift = Tensor::from_values(lift, {nf + ns, 3}, DType::Float64);
  s.colours = Tensor::from_values(colours, {nf + ns, 3}, DType::Float64);
  s.triangles = Tensor::from_vector(tris, {static_cast<std::int64_t>(tris.size() / 3), 3});
  s.topology = antialias_topology(s.triangles, s.base);
  return s;
}

// The camera straight above the floor's centre, looking down -z.
Tensor view_projection() {
  return matmul(perspective(Tensor::scalar(0.7, DType::Float64), 1.0, 0.5, 10.0),
                look_at(Tensor::from_values({0, 0, 3}, {3}, DType::Float64), Tensor::zeros({3}, DType::Float64),
                        Tensor::from_values({0, 1, 0}, {3}, DType::Float64)));
}

Tensor render(const Scene& s, const Tensor& height, const Tensor& mvp, int size, bool visibility) {
  const Tensor clip = transform_points(s.base + s.lift * height, mvp);
  const GBuffer gb = rasterize(clip, s.triangles, {size, size});
  const Tensor image = interpolate(s.colours, gb, s.triangles);
  if (visibility) {
    VisibilityAntialiasOptions options;
    options.topology = s.topology;
    return visibility_antialias(image, gb, clip, s.triangles, options);
  }
  AntialiasOptions options;
  options.topology = s.topology;
  return antialias(image, gb, clip, s.triangles, options);
}

}  // namespace

SunkSphereRun fit_sunk_sphere(const SunkSphereOptions& o, bool visibility) {
  const Scene scene = make_scene();
  const Tensor mvp = view_projection();
  Tensor target;
  {
    NoGradGuard no_grad;
    target = render(scene, Tensor::scalar(o.true_height, DType::Float64), mvp, o.size, visibility);
  }
  Tensor height = Tensor::scalar(o.start_height, DType::Float64).set_requires_grad();
  Adam adam({height}, AdamOptions{o.learning_rate});
  SunkSphereRun run;
  run.visibility = visibility;
  run.height.push_back(height.item());
  for (int i = 0; i < o.iterations; ++i) {
    const Tensor loss = mean(pow(render(scene, height, mvp, o.size, visibility) - target, 2.0));
    backward(loss);
    run.loss.push_back(loss.item());
    adam.step();
    adam.zero_grad();
    run.height.push_back(height.item());
  }
  return run;
}

}  // namespace gr::intersection_example
