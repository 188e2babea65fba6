// Golden checksums: fixed scenes rendered and differentiated with 1, 2 and 8
// threads (8 really is 8 threads, also on fewer cores: autodiff/base/parallel.h),
// each thread count twice. Every buffer (G-buffer, image, every gradient) is
// hashed (FNV-1a over its raw bytes) and all runs must agree bit for bit, in
// float32 and float64. The hashes are compared between runs, never with
// stored values (those depend on the compiler's floating-point code).
//
// The images are large enough that every parallel loop really splits: 288 x 256
// pixels are 73728 (rasterize adjoint: 16384-pixel chunks in 1024-pixel
// grains; elementwise grain 16384 elements), the mesh has 20480 triangles
// (rasterize bins in 4096-triangle chunks) and 10242 vertices; the texture
// adjoint splits texels into one band per thread. docs/determinism.md.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "ops/render/antialias.h"
#include "ops/ops.h"
#include "ops/render/ssr.h"
#include "raster/procedural.h"
#include "examples/common/ssr_scene.h"

using namespace gr;

namespace {

// FNV-1a (64 bit) over a tensor's raw bytes; undefined tensors hash to 0.
std::uint64_t fnv1a(const Tensor& t) {
  if (!t.defined()) return 0;
  const unsigned char* bytes = nullptr;
  switch (t.dtype()) {
    case DType::Float32: bytes = reinterpret_cast<const unsigned char*>(t.data<float>()); break;
    case DType::Float64: bytes = reinterpret_cast<const unsigned char*>(t.data<double>()); break;
    case DType::Int32: bytes = reinterpret_cast<const unsigned char*>(t.data<std::int32_t>()); break;
  }
  const std::size_t n = static_cast<std::size_t>(t.numel()) * dtype_size(t.dtype());
  std::uint64_t h = 14695981039346656037ull;
  for (std::size_t i = 0; i < n; ++i) {
    h ^= bytes[i];
    h *= 1099511628211ull;
  }
  return h;
}

// Named hashes of one run, in a fixed order.
using Hashes = std::vector<std::pair<std::string, std::uint64_t>>;

// Sets the thread count for one run and restores the default after it.
struct ThreadCount {
  explicit ThreadCount(int n) { set_num_threads(n); }
  ~ThreadCount() { set_num_threads(0); }
};

// Runs `scene` for each thread count in 1, 2, 8, 1, 2, 8 and fails, naming the
// buffer, for every hash that differs from the first run's.
void require_identical_runs(const std::string& what, const std::function<Hashes()>& scene) {
  const int threads[] = {1, 2, 8, 1, 2, 8};
  std::vector<Hashes> runs;
  for (int n : threads) {
    ThreadCount count(n);
    runs.push_back(scene());
  }
  for (std::size_t r = 1; r < runs.size(); ++r) {
    REQUIRE(runs[r].size() == runs[0].size());
    for (std::size_t b = 0; b < runs[0].size(); ++b)
      if (runs[r][b].second != runs[0][b].second)
        FAIL_CHECK(what << ": buffer '" << runs[0][b].first << "' differs between " << threads[0]
                        << " thread(s) (run 1) and " << threads[r] << " thread(s) (run " << r + 1 << ")");
  }
}

// Pixels with a non-zero id in an int32 [H, W] mask.
std::int64_t covered(const Tensor& mask) {
  const std::int32_t* m = mask.data<std::int32_t>();
  std::int64_t n = 0;
  for (std::int64_t i = 0; i < mask.numel(); ++i) n += m[i] != 0;
  return n;
}

// The scene is not degenerate: a gradient exists and is not all zeros.
bool nonzero_grad(const Tensor& leaf) {
  if (!leaf.grad().defined()) return false;
  for (double g : leaf.grad().to_vector())
    if (g != 0) return true;
  return false;
}

Tensor vec3(double x, double y, double z, DType dtype) { return Tensor::from_values({x, y, z}, {3}, dtype); }

// ----------------------------------------------------------------- pipeline

// A bumpy icosphere with vertex colours and a texture, seen by a camera with
// learnable eye, field of view and model rotation.
struct PipelineScene {
  Tensor positions, colours, texture, eye, fov, angle;  // leaves (require grad)
  Tensor normals, uvs, triangles, edge_a, edge_b, weights;
  AntialiasTopology topology;
  int width = 288, height = 256;
};

PipelineScene make_pipeline_scene(DType dtype) {
  const raster::Mesh mesh = raster::make_icosphere(5, 0.9f);  // 20480 triangles
  std::vector<double> p = mesh.positions.to_vector();
  for (std::size_t i = 0; i < p.size(); i += 3) {  // radial bumps
    const double s = 1.0 + 0.12 * std::sin(5 * p[i]) * std::cos(4 * p[i + 1]) + 0.06 * std::sin(7 * p[i + 2]);
    for (int k = 0; k < 3; ++k) p[i + k] *= s;
  }
  const std::int64_t n = mesh.num_vertices();
  PipelineScene s;
  s.positions = Tensor::from_values(p, {n, 3}, dtype).set_requires_grad();
  s.colours = Tensor::uniform({n, 3}, 0.2, 1.0, 7, dtype).set_requires_grad();
  s.texture = Tensor::uniform({128, 128, 3}, 0.0, 1.0, 8, dtype).set_requires_grad();
  s.eye = vec3(0.4, 0.5, 2.7, dtype).set_requires_grad();
  s.fov = Tensor::scalar(0.85, dtype).set_requires_grad();
  s.angle = Tensor::from_values({0.3}, {1}, dtype).set_requires_grad();
  s.normals = cast(mesh.normals, dtype);
  s.uvs = cast(mesh.uvs, dtype);
  s.triangles = mesh.triangles;
  // Edges (a, b) of every triangle for a smoothness term (gather / scatter_add adjoint).
  std::vector<std::int32_t> a, b;
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  for (std::int64_t k = 0; k < mesh.num_triangles(); ++k)
    for (int e = 0; e < 3; ++e) {
      a.push_back(t[3 * k + e]);
      b.push_back(t[3 * k + (e + 1) % 3]);
    }
  s.edge_a = Tensor::from_vector(a, {static_cast<std::int64_t>(a.size())});
  s.edge_b = Tensor::from_vector(b, {static_cast<std::int64_t>(b.size())});
  s.weights = Tensor::uniform({s.height, s.width, 3}, -1.0, 1.0, 9, dtype);
  s.topology = antialias_topology(s.triangles, s.positions);
  return s;
}

Hashes run_pipeline(PipelineScene& s) {
  const DType dt = s.positions.dtype();
  for (Tensor* leaf : {&s.positions, &s.colours, &s.texture, &s.eye, &s.fov, &s.angle}) leaf->zero_grad();
  const Tensor model = matmul(translate(vec3(0.05, -0.02, 0.0, dt)), rotate_y(s.angle));
  const Tensor view = look_at(s.eye, vec3(0, 0, 0, dt), vec3(0, 1, 0, dt));
  const Tensor mvp = matmul(perspective(s.fov, double(s.width) / s.height, 0.5, 10.0), matmul(view, model));
  const Tensor clip = transform_points(s.positions, mvp);
  RasterizeOptions raster{s.width, s.height};
  raster.derivatives = true;
  const GBuffer gb = rasterize(clip, s.triangles, raster);

  // Trilinear texture with the analytic uv derivatives, times vertex colours.
  const InterpolatedWithDerivatives uv = interpolate_with_derivatives(s.uvs, gb, s.triangles);
  TextureOptions topt;
  topt.filter = Filter::Trilinear;
  const Tensor texel = texture(s.texture, uv.values, topt, uv.d_dx, uv.d_dy);
  const Tensor albedo = interpolate(s.colours, gb, s.triangles) * texel;

  // Blinn-Phong in model space.
  const Tensor n = normalize(interpolate(s.normals, gb, s.triangles));
  const Tensor p = interpolate(s.positions, gb, s.triangles);
  const Tensor light = normalize(vec3(0.5, 0.8, 1.0, dt));
  const Tensor v = normalize(s.eye - p);
  const Tensor h = normalize(light + v);
  const Tensor diffuse = maximum(dot(n, light), 0.0);
  const Tensor specular = pow(maximum(dot(n, h), 0.0), 32.0);
  const Tensor shaded = albedo * (0.2 + 0.8 * diffuse) + 0.3 * specular;

  AntialiasOptions aopt;
  aopt.topology = s.topology;
  const Tensor image = antialias(shaded, gb, clip, s.triangles, aopt);
  const Tensor smooth = sum(pow(gather(s.positions, s.edge_a) - gather(s.positions, s.edge_b), 2.0));
  const Tensor loss = mean(image * s.weights) + 1e-3 * smooth + 0.1 * mean(gb.depth);
  backward(loss);
  // Most pixels covered, every leaf reached.
  CHECK(covered(gb.tri_id) > s.width * s.height / 3);
  for (Tensor* leaf : {&s.positions, &s.colours, &s.texture, &s.eye, &s.fov, &s.angle}) CHECK(nonzero_grad(*leaf));

  return {{"tri_id", fnv1a(gb.tri_id)},
          {"uv (barycentrics)", fnv1a(gb.uv)},
          {"depth", fnv1a(gb.depth)},
          {"uv d/dx", fnv1a(uv.d_dx)},
          {"uv d/dy", fnv1a(uv.d_dy)},
          {"texel", fnv1a(texel)},
          {"shaded", fnv1a(shaded)},
          {"image", fnv1a(image)},
          {"loss", fnv1a(loss)},
          {"grad positions", fnv1a(s.positions.grad())},
          {"grad colours", fnv1a(s.colours.grad())},
          {"grad texture", fnv1a(s.texture.grad())},
          {"grad eye", fnv1a(s.eye.grad())},
          {"grad fov", fnv1a(s.fov.grad())},
          {"grad angle", fnv1a(s.angle.grad())}};
}

// ---------------------------------------------------------------------- SSR

struct SsrSceneTensors {
  Tensor positions, colours, reflectivity;  // leaves
  SsrFade fade;                             // leaves
  Tensor normals, triangles, weights;
  gr::examples::SsrScene scene;
  int width = 256, height = 192;
};

SsrSceneTensors make_ssr_tensors(DType dtype) {
  SsrSceneTensors s;
  s.scene = gr::examples::make_ssr_scene(8, 3);
  s.positions = cast(s.scene.mesh.positions, dtype).set_requires_grad();
  s.normals = cast(s.scene.mesh.normals, dtype);
  s.colours = cast(s.scene.colours, dtype).set_requires_grad();
  s.reflectivity = Tensor::full({1}, 0.6, dtype).set_requires_grad();
  s.triangles = s.scene.mesh.triangles;
  s.weights = Tensor::uniform({s.height, s.width, 3}, -1.0, 1.0, 10, dtype);
  return s;
}

SsrOptions ssr_options() {
  SsrOptions o;
  o.tracer = SsrTracer::Dda;
  o.max_distance = 8;
  o.thickness = 0.3;
  o.binary_steps = 4;
  return o;
}

Hashes run_ssr(SsrSceneTensors& s) {
  const DType dt = s.positions.dtype();
  s.fade = ssr_fade(ssr_options(), dt);
  for (Tensor* leaf : {&s.fade.edge_exponent, &s.fade.fade_distance}) leaf->set_requires_grad();
  for (Tensor* leaf : {&s.positions, &s.colours, &s.reflectivity}) leaf->zero_grad();
  const gr::examples::SsrScene& sc = s.scene;
  const Tensor view = look_at(vec3(sc.eye[0], sc.eye[1], sc.eye[2], dt), vec3(sc.target[0], sc.target[1], sc.target[2], dt),
                              vec3(sc.up[0], sc.up[1], sc.up[2], dt));
  const Tensor proj = perspective(sc.fov_y, double(s.width) / s.height, sc.near, sc.far, ClipSpace::OpenGL, dt);
  const ViewSpaceMesh vs = ssr_view_space(s.positions, s.normals, view);
  const SsrGBuffer g = ssr_gbuffer(vs.positions, vs.normals, s.colours, s.triangles, proj, {s.width, s.height});
  const SsrTrace t = ssr_trace(g, proj, ssr_options());
  const SsrComposite c = ssr_composite(g.colour, t, s.reflectivity, s.fade);
  backward(mean(c.image * s.weights));
  CHECK(covered(g.mask) > s.width * s.height / 3);
  CHECK(t.stats.hits > 1000);
  for (Tensor* leaf : {&s.colours, &s.reflectivity, &s.fade.edge_exponent, &s.fade.fade_distance})
    CHECK(nonzero_grad(*leaf));
  // Each object has one colour: the interpolated colour does not depend on the
  // barycentrics, and the trace is a constant for the tape, so the positions
  // get an exact zero (no antialias here to give the silhouettes a gradient).
  CHECK(!nonzero_grad(s.positions));
  return {{"position", fnv1a(g.position)},
          {"normal", fnv1a(g.normal)},
          {"colour", fnv1a(g.colour)},
          {"mask", fnv1a(g.mask)},
          {"hit", fnv1a(t.hit)},
          {"hit_xy", fnv1a(t.hit_xy)},
          {"hit_distance", fnv1a(t.hit_distance)},
          {"confidence", fnv1a(c.confidence)},
          {"image", fnv1a(c.image)},
          {"grad positions", fnv1a(s.positions.grad())},
          {"grad colours", fnv1a(s.colours.grad())},
          {"grad reflectivity", fnv1a(s.reflectivity.grad())},
          {"grad edge_exponent", fnv1a(s.fade.edge_exponent.grad())},
          {"grad fade_distance", fnv1a(s.fade.fade_distance.grad())}};
}

}  // namespace

TEST_CASE("determinism: pipeline buffers and gradients are bit-identical for 1, 2 and 8 threads",
          "[stress][determinism]") {
  for (DType dt : {DType::Float32, DType::Float64}) {
    PipelineScene s = make_pipeline_scene(dt);
    require_identical_runs(std::string("pipeline ") + dtype_name(dt), [&] { return run_pipeline(s); });
  }
}

TEST_CASE("determinism: SSR buffers and gradients are bit-identical for 1, 2 and 8 threads",
          "[stress][determinism][ssr]") {
  for (DType dt : {DType::Float32, DType::Float64}) {
    SsrSceneTensors s = make_ssr_tensors(dt);
    require_identical_runs(std::string("ssr ") + dtype_name(dt), [&] { return run_ssr(s); });
  }
}
