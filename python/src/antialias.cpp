#include "python/src/antialias.h"

#include <algorithm>
#include <string>

#include "autodiff/error.h"
#include "autodiff/memory.h"
#include "raster/rasterize_setup.h"

namespace gr::python {
namespace {

// Our antialias kernel reads an int32 id image and a depth image: both are
// taken from rast's channels 3 and 2 (one pass over the G-buffer).
template <class T>
void split_rast(const T* rast, std::int64_t pixels, std::vector<std::int32_t>* tri_id, std::vector<T>* depth) {
  tri_id->resize(static_cast<std::size_t>(pixels));
  depth->resize(static_cast<std::size_t>(pixels));
  for (std::int64_t q = 0; q < pixels; ++q) {
    (*tri_id)[q] = static_cast<std::int32_t>(rast[4 * q + 3]);
    (*depth)[q] = rast[4 * q + 2];
  }
}

// Image b's kernel inputs, its ids, depths and flipped positions in s.
template <class T>
raster::AntialiasParams<T> image_params(ImageScratch& s, const Mesh& mesh, const Topology& topology, Address color,
                                        Address rast, std::int64_t channels, int height, int width, std::int64_t b) {
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  copy_flipped(at<const T>(mesh.pos) + mesh.pos_offset(b), mesh.vertices, &s.buffer<T>(ImageScratch::kClip));
  split_rast(at<const T>(rast) + 4 * pixels * b, pixels, &s.tri_id, &s.buffer<T>(ImageScratch::kDepth));
  raster::AntialiasParams<T> p;
  p.image = at<const T>(color) + pixels * channels * b;
  p.channels = static_cast<int>(channels);
  p.width = width;
  p.height = height;
  p.tri_id = s.tri_id.data();
  p.depth = s.buffer<T>(ImageScratch::kDepth).data();
  p.clip = s.buffer<T>(ImageScratch::kClip).data();
  p.num_vertices = mesh.vertices;
  p.tris = at<const std::int32_t>(mesh.tri);
  p.num_tris = mesh.triangles;
  p.topology = &topology.edges;
  return p;
}

}  // namespace

std::shared_ptr<Topology> build_topology(Address tri, std::int64_t triangles, std::int64_t vertices,
                                         const std::string& op) {
  const auto* t = at<const std::int32_t>(tri);
  if (vertices >= 0) {
    raster::detail::check_triangles(t, triangles, vertices, op.c_str());
  } else {
    for (std::int64_t i = 0; i < 3 * triangles; ++i)
      if (t[i] < 0)
        throw IndexError(op + ": tri[" + std::to_string(i / 3) + "] has the negative index " + std::to_string(t[i]));
  }
  check_memory_request(raster::edge_topology_bytes(triangles),
                       op + ": the edge adjacency of " + std::to_string(triangles) + " triangles");
  auto topology = std::make_shared<Topology>();
  topology->edges = raster::build_edge_topology(t, triangles);
  topology->triangles = triangles;
  return topology;
}

std::shared_ptr<AntialiasState> antialias_forward(Context& ctx, const Mesh& mesh, const Topology& topology,
                                                  Address color, std::int64_t channels, int height, int width,
                                                  Address rast, Address out, bool visibility, int threads) {
  KernelCall call(threads);
  const char* op = visibility ? "visibility_antialias" : "antialias";
  check_mesh(mesh, op);
  if (topology.triangles != mesh.triangles)
    throw ValueError(std::string(op) + ": 'topology_hash' was built for " + std::to_string(topology.triangles) +
                     " triangles but 'tri' has " + std::to_string(mesh.triangles));
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  auto state = std::make_shared<AntialiasState>();
  state->pairs.resize(static_cast<std::size_t>(mesh.images));
  ctx.reserve(mesh.images);
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    check_rast_ids(at<const T>(rast), mesh.images * pixels, mesh.triangles, "rast", op);
    for_each_image(mesh.images, [&](std::int64_t b) {
      const auto p = image_params<T>(ctx.image(b), mesh, topology, color, rast, channels, height, width, b);
      raster::blend_boundaries_forward(visibility, p, at<T>(out) + pixels * channels * b, &state->pairs[b]);
    });
  });
  return state;
}

void antialias_backward(Context& ctx, const Mesh& mesh, const Topology& topology, const AntialiasState& state,
                        Address color, std::int64_t channels, int height, int width, Address rast,
                        Address grad_out, Address grad_color, Address grad_pos, double pos_gradient_boost,
                        int threads) {
  KernelCall call(threads);
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  ctx.reserve(mesh.images);
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    // Per image: the colour gradient in place, the position gradient in the
    // image's buffer (scaled by the boost), then added as rasterize's is.
    for_each_image(mesh.images, [&](std::int64_t b) {
      ImageScratch& s = ctx.image(b);
      const auto p = image_params<T>(s, mesh, topology, color, rast, channels, height, width, b);
      std::vector<T>& grad = s.buffer<T>(ImageScratch::kGrad);
      raster::AntialiasGrads<T> g;
      if (grad_color) g.image = at<T>(grad_color) + pixels * channels * b;
      if (grad_pos) {
        grad.assign(4 * static_cast<std::size_t>(mesh.vertices), T(0));
        g.clip = grad.data();
      }
      raster::blend_boundaries_backward(p, state.pairs[b], at<const T>(grad_out) + pixels * channels * b, g);
      if (!grad_pos) return;
      for (T& v : grad) v = static_cast<T>(pos_gradient_boost * v);
      if (mesh.instanced) add_flipped(grad.data(), mesh.vertices, at<T>(grad_pos) + mesh.pos_offset(b));
    });
    if (grad_pos && !mesh.instanced)
      for (std::int64_t b = 0; b < mesh.images; ++b)
        add_flipped(ctx.image(b).buffer<T>(ImageScratch::kGrad).data(), mesh.vertices, at<T>(grad_pos));
  });
}

}  // namespace gr::python
