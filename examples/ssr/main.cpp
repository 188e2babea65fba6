// gradraster-ssr: screen-space reflections on a glossy floor. Renders the SSR
// scene (checker floor, two spheres, a box), shades it with a Lambert light,
// traces reflections with the McGuire-Mara DDA and composites them. Writes
// <out>/ssr_example.png: base shading | with reflections | raw (unblurred)
// reflection, and the same for the view-space tracer to ssr_example_viewspace.png.
//   gradraster-ssr [out_dir] [width] [height]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "autodiff/tape.h"
#include "ops/elementwise.h"
#include "ops/shape_ops.h"
#include "ops/ssr.h"
#include "ops/transforms.h"
#include "ops/vector.h"
#include "raster/image_io.h"
#include "raster/ssr_scene.h"

using namespace gr;

namespace {

Tensor vec3(const std::array<double, 3>& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}); }

}  // namespace

int main(int argc, char** argv) {
  const std::string out_dir = argc > 1 ? argv[1] : "out";
  const int W = argc > 2 ? std::atoi(argv[2]) : 480;
  const int H = argc > 3 ? std::atoi(argv[3]) : 360;
  if (W < 8 || H < 8 || W > 4096 || H > 4096) {
    std::fprintf(stderr, "gradraster-ssr: width and height must be in 8..4096\n");
    return 2;
  }
  try {
    NoGradGuard no_grad;
    std::filesystem::create_directories(out_dir);
    const raster::SsrScene s = raster::make_ssr_scene(8, 4, 0.65f);
    const Tensor view = look_at(vec3(s.eye), vec3(s.target), vec3(s.up));
    const Tensor proj = perspective(s.fov_y, double(W) / H, s.near, s.far);
    const ViewSpaceMesh vs = ssr_view_space(s.mesh.positions, s.mesh.normals, view);
    // G-buffer: view-space position and normal, albedo and reflectivity (4 channels).
    const SsrGBuffer g = ssr_gbuffer(vs.positions, vs.normals, concat({s.colours, s.reflectivity}, 1),
                                     s.mesh.triangles, proj, {W, H, /*back_faces=*/true});
    const Tensor albedo = slice(g.colour, 2, 0, 3), reflectivity = slice(g.colour, 2, 3, 4);
    // Lambert shading with a light from the upper left (view space) plus ambient; a dark sky.
    const Tensor light = normalize(Tensor::from_values({-0.5, 0.8, 0.45}, {3}));
    const Tensor lit = albedo * (0.3 + 0.7 * maximum(dot(g.normal, light), 0.0));
    const Tensor covered = reshape(cast(greater(cast(g.mask, DType::Float32), Tensor::scalar(0)), DType::Float32), {H, W, 1});
    const Tensor sky = Tensor::from_values({0.08, 0.1, 0.16}, {3});
    const Tensor base = where(covered, lit, sky);

    for (SsrTracer tracer : {SsrTracer::Dda, SsrTracer::ViewSpace}) {
      SsrOptions o;
      o.tracer = tracer;
      o.near = s.near;
      o.max_distance = 8;
      o.thickness = 0.25;
      o.max_steps = tracer == SsrTracer::Dda ? 512 : 128;
      o.binary_steps = 6;
      o.stride = 2, o.jitter = 1, o.stride_z_cutoff = 20;
      o.edge_form = EdgeFade::Circular, o.edge_exponent = 3;
      o.fade_distance = 6, o.fade_exponent = 2;
      const auto t0 = std::chrono::steady_clock::now();
      const SsrTrace t = ssr_trace(g, proj, o);
      const auto t1 = std::chrono::steady_clock::now();
      const SsrComposite c = ssr_composite(base, t, reflectivity, ssr_fade(o));
      const double ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
      const std::string name = tracer == SsrTracer::Dda ? "ssr_example.png" : "ssr_example_viewspace.png";
      const std::string path = (std::filesystem::path(out_dir) / name).string();
      raster::write_png(path, concat({base, c.image, c.reflection}, 1));
      std::printf("%s: %s tracer, %lld rays, %lld hits, %lld depth samples, trace %.1f ms\n", path.c_str(),
                  tracer == SsrTracer::Dda ? "DDA" : "view-space", (long long)t.stats.rays, (long long)t.stats.hits,
                  (long long)t.stats.samples, ms);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gradraster-ssr: %s\n", e.what());
    return 1;
  }
  return 0;
}
