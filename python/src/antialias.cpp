#include "python/src/antialias.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "python/src/backend.h"
#include "raster/mesh_checks.h"

namespace gr::python {
namespace {

// Our antialias kernel reads an int32 id image and a depth image: both are
// taken from rast's channels 3 and 2 (one pass over the G-buffer, which also
// checks the ids: false when one is not an integer in [0, triangles]; a bad
// id becomes 0, and the caller throws check_rast_ids's error).
template <class T>
bool split_rast(const T* rast, std::int64_t pixels, std::int64_t triangles, std::vector<std::int32_t>* tri_id,
                std::vector<T>* depth) {
  tri_id->resize(static_cast<std::size_t>(pixels));
  depth->resize(static_cast<std::size_t>(pixels));
  const T top = static_cast<T>(triangles);
  bool ok = true;
  for (std::int64_t q = 0; q < pixels; ++q) {
    const T id = rast[4 * q + 3];
    const bool good = (id >= 0) & (id <= top) & (id == std::floor(id));
    ok &= good;
    (*tri_id)[q] = good ? static_cast<std::int32_t>(id) : 0;
    (*depth)[q] = rast[4 * q + 2];
  }
  return ok;
}

// Image b's kernel inputs, its ids and depths in s (the kernels read the
// caller's positions with y_up); *ids_ok: whether its ids are valid (split_rast).
// visibility: for a backend's calls (the CPU's take it as an argument).
template <class T>
raster::AntialiasParams<T> image_params(ImageScratch& s, const Mesh& mesh, const Topology& topology,
                                        const Array& color, const Array& rast, std::int64_t b, bool visibility,
                                        bool* ids_ok) {
  const int height = static_cast<int>(color.size(1)), width = static_cast<int>(color.size(2));
  const std::int64_t channels = color.size(3);
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  *ids_ok = split_rast(rast.in<T>() + 4 * pixels * b, pixels, mesh.triangles, &s.tri_id,
                       &s.buffer<T>(ImageScratch::kDepth));
  raster::AntialiasParams<T> p;
  p.image = color.in<T>() + pixels * channels * b;
  p.channels = static_cast<int>(channels);
  p.width = width;
  p.height = height;
  p.tri_id = s.tri_id.data();
  p.depth = s.buffer<T>(ImageScratch::kDepth).data();
  p.clip = mesh.positions<T>(b);
  p.num_vertices = mesh.vertices;
  p.tris = mesh.tris();
  p.num_tris = mesh.triangles;
  p.topology = &topology.edges;
  p.y_up = true;  // nvdiffrast's row 0 is the bottom row
  p.visibility = visibility;
  return p;
}

// The shapes both directions read: color [images, H, W, C] (C >= 1) and rast
// [images, H, W, 4], of pos's dtype.
void check_shapes(const Mesh& mesh, const Array& color, const Array& rast, const char* op) {
  color.required().same_elem(mesh.pos).rank({4});
  check_rast_shape(rast, mesh.images, mesh.pos.elem(), op);
  color.shape({rast.size(0), rast.size(1), rast.size(2), -1}, "[minibatch_size, height, width, channels] as 'rast'");
  if (color.size(3) < 1 || color.size(3) > INT32_MAX)
    throw ValueError(std::string(op) + ": 'color' needs 1.." + std::to_string(INT32_MAX) + " channels, got " +
                     std::to_string(color.size(3)));
}

// Image b's copy in kept (may be null; null: the device uploads) and the
// row of p's whole list its triangles start at: the edge topology indexes
// the whole list, so a range's copy is read with it, its ids offset by the
// range's first row (raster::image_on_device).
raster::ImageOnDevice on_device(const DeviceGBuffers* kept, std::int64_t b, const raster::AntialiasParams<float>& p) {
  const std::int64_t pixels = static_cast<std::int64_t>(p.width) * p.height;
  return image_on_device(kept, b, p.tris, p.num_tris, p.tri_id, pixels, true);
}

void check_topology(const Topology& topology, const Mesh& mesh, const char* op) {
  if (topology.triangles != mesh.triangles)
    throw ValueError(std::string(op) + ": 'topology_hash' was built for " + std::to_string(topology.triangles) +
                     " triangles but 'tri' has " + std::to_string(mesh.triangles));
}

}  // namespace

std::shared_ptr<Topology> build_topology(const pybind11::object& tri_, std::int64_t vertices, const std::string& op) {
  const Array tri(tri_, op, "tri");
  tri.elem_in({Elem::I32}).rank({2}).shape({-1, 3}, "[num_triangles, 3]");
  const std::int64_t triangles = tri.size(0);
  const std::int32_t* t = tri.in<std::int32_t>();
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
  std::int32_t largest = -1;
  for (std::int64_t i = 0; i < 3 * triangles; ++i) largest = std::max(largest, t[i]);
  topology->vertices_needed = std::int64_t(largest) + 1;
  return topology;
}

std::shared_ptr<AntialiasState> antialias_forward(Context& ctx, const pybind11::object& pos,
                                                  const pybind11::object& tri, Ranges ranges, const Topology& topology,
                                                  const pybind11::object& color_, const pybind11::object& rast_,
                                                  const pybind11::object& out_, bool visibility, int threads,
                                                  std::shared_ptr<DeviceGBuffers> kept) {
  const char* op = visibility ? "visibility_antialias" : "antialias";
  const Mesh mesh(pos, tri, ranges, op);
  const Array color(color_, op, "color"), rast(rast_, op, "rast"), out(out_, op, "out");
  check_shapes(mesh, color, rast, op);
  out.same_elem(color).shape(color.shape());
  check_disjoint(op, {&out}, {&mesh.pos, &mesh.tri, &color, &rast});
  KernelCall call(threads);
  check_mesh(mesh, op);
  check_topology(topology, mesh, op);
  check_kept(kept.get(), mesh.images, op);
  const std::int64_t pixels = color.size(1) * color.size(2), channels = color.size(3);
  auto state = std::make_shared<AntialiasState>();
  state->pairs.resize(static_cast<std::size_t>(mesh.images));
  state->height = color.size(1);
  state->width = color.size(2);
  state->channels = channels;
  state->vertices = mesh.vertices;
  state->triangles = mesh.triangles;
  state->visibility = visibility;
  state->on_backend.assign(static_cast<std::size_t>(mesh.images), 0);
  state->device_pairs.resize(static_cast<std::size_t>(mesh.images));
  ctx.reserve(mesh.images);
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    if (backend_for<T>(&ctx)) state->backend = ctx.backend, state->kept = kept;
    std::atomic<bool> bad_ids{false};
    for_each_image_on(state->backend.get(), mesh.images, [&](std::int64_t b) {
      bool ids_ok = true;
      const auto p = image_params<T>(ctx.image(b), mesh, topology, color, rast, b, visibility, &ids_ok);
      if (!ids_ok) return bad_ids.store(true);
      T* o = out.out<T>() + pixels * channels * b;
      if constexpr (std::is_same_v<T, float>)
        if (state->backend) {
          const raster::ImageOnDevice on = on_device(state->kept.get(), b, p);
          if (counted(ctx, state->backend->antialias_forward(on.device, on.first, p, o, &state->device_pairs[b]))) {
            state->on_backend[b] = 1;
            return;
          }
        }
      raster::blend_boundaries_forward(visibility, p, o, &state->pairs[b]);
    });
    if (bad_ids) raster::detail::check_rast_ids(rast.in<T>(), mesh.images * pixels, mesh.triangles, "rast", op);  // throws
  });
  return state;
}

void antialias_backward(Context& ctx, const pybind11::object& pos, const pybind11::object& tri, Ranges ranges,
                        const Topology& topology, const AntialiasState& state, const pybind11::object& color_,
                        const pybind11::object& rast_, const pybind11::object& grad_out_,
                        const pybind11::object& grad_color_, const pybind11::object& grad_pos_,
                        double pos_gradient_boost, int threads) {
  const char* op = state.visibility ? "visibility_antialias backward" : "antialias backward";
  const Mesh mesh(pos, tri, ranges, op);
  const Array color(color_, op, "color"), rast(rast_, op, "rast"), grad_out(grad_out_, op, "grad_out"),
      grad_color(grad_color_, op, "grad_color", true), grad_pos(grad_pos_, op, "grad_pos", true);
  check_shapes(mesh, color, rast, op);
  // The pairs index the forward's pixels, channels and vertices.
  if (static_cast<std::int64_t>(state.pairs.size()) != mesh.images || state.height != color.size(1) ||
      state.width != color.size(2) || state.channels != color.size(3) || state.vertices != mesh.vertices ||
      state.triangles != mesh.triangles)
    throw ValueError(std::string(op) + ": the state is of a forward call with " + std::to_string(state.pairs.size()) +
                     " images of " + std::to_string(state.height) + " x " + std::to_string(state.width) + " x " +
                     std::to_string(state.channels) + ", " + std::to_string(state.vertices) + " vertices and " +
                     std::to_string(state.triangles) + " triangles; these inputs differ");
  if (state.backend && mesh.f64)
    throw DTypeError(std::string(op) + ": the state is of a float32 forward call on the device; these inputs are "
                     "float64");
  if (!std::isfinite(pos_gradient_boost))
    throw ValueError(std::string(op) + ": 'pos_gradient_boost' must be a finite number, got " +
                     std::to_string(pos_gradient_boost));
  grad_out.same_elem(color).shape(color.shape());
  grad_color.same_elem(color).shape(color.shape());
  grad_pos.same_elem(mesh.pos).shape(mesh.pos.shape());
  check_disjoint(op, {&grad_color, &grad_pos}, {&mesh.pos, &mesh.tri, &color, &rast, &grad_out});
  KernelCall call(threads);
  check_mesh(mesh, op);
  check_topology(topology, mesh, op);
  const std::int64_t pixels = color.size(1) * color.size(2), channels = color.size(3);
  ctx.reserve(mesh.images);
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    std::atomic<bool> bad_ids{false};
    // Per image: the colour gradient in place, the position gradient in the
    // image's buffer (scaled by the boost), then added as rasterize's is.
    for_each_image_on(state.backend.get(), mesh.images, [&](std::int64_t b) {
      ImageScratch& s = ctx.image(b);
      bool ids_ok = true;
      const auto p = image_params<T>(s, mesh, topology, color, rast, b, state.visibility, &ids_ok);
      if (!ids_ok) return bad_ids.store(true);
      std::vector<T>& grad = s.buffer<T>(ImageScratch::kGrad);
      raster::AntialiasGrads<T> g;
      if (grad_color) g.image = grad_color.out<T>() + pixels * channels * b;
      if (grad_pos) {
        grad.assign(4 * static_cast<std::size_t>(mesh.vertices), T(0));
        g.clip = grad.data();
      }
      const T* g_out = grad_out.in<T>() + pixels * channels * b;
      if (!state.on_backend[b]) {
        raster::blend_boundaries_backward(p, state.pairs[b], g_out, g);
      } else if constexpr (std::is_same_v<T, float>) {
        const raster::ImageOnDevice on = on_device(state.kept.get(), b, p);
        if (!counted(ctx, state.backend->antialias_backward(on.device, on.first, p, g_out, g,
                                                            state.device_pairs[b].get())))
          throw Error(std::string(op) + ": the device ran the forward but refused the adjoint");
      }
    }, [&](std::int64_t b) {  // once the device's calls have written their gradients
      if (!grad_pos || bad_ids) return;
      std::vector<T>& grad = ctx.image(b).buffer<T>(ImageScratch::kGrad);
      for (T& v : grad) v = static_cast<T>(pos_gradient_boost * v);
      const T* part = grad.data();
      if (mesh.instanced) raster::sum_in_image_order(&part, 1, 4 * mesh.vertices, grad_pos.out<T>() + mesh.pos_offset(b));
    });
    if (bad_ids) raster::detail::check_rast_ids(rast.in<T>(), mesh.images * pixels, mesh.triangles, "rast", op);  // throws
    if (grad_pos && !mesh.instanced)
      raster::sum_in_image_order(ctx.grads<T>(mesh.images).data(), mesh.images, 4 * mesh.vertices, grad_pos.out<T>());
  });
}

}  // namespace gr::python
