#include "python/src/rasterize.h"

#include <algorithm>

#include "raster/barycentric_gbuffer.h"
#include "raster/rasterize.h"

namespace gr::python {

template <>
std::vector<float>& Context::uv<float>() { return uv_f; }
template <>
std::vector<double>& Context::uv<double>() { return uv_d; }
template <>
std::vector<float>& Context::depth<float>() { return depth_f; }
template <>
std::vector<double>& Context::depth<double>() { return depth_d; }
template <>
std::vector<float>& Context::clip<float>() { return clip_f; }
template <>
std::vector<double>& Context::clip<double>() { return clip_d; }
template <>
std::vector<float>& Context::grad<float>() { return grad_f; }
template <>
std::vector<double>& Context::grad<double>() { return grad_d; }

void rasterize_forward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address db,
                       PeelState* peel, int threads) {
  KernelCall call(threads);
  check_mesh(mesh, "rasterize");
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  if (peel && peel->floor_id.empty()) {
    peel->floor_id.assign(static_cast<std::size_t>(mesh.images * pixels), 0);
    peel->floor_z.assign(static_cast<std::size_t>(mesh.images * pixels), 0.0);
  }
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    ctx.tri_id.resize(static_cast<std::size_t>(pixels));
    ctx.uv<T>().resize(2 * static_cast<std::size_t>(pixels));
    ctx.depth<T>().resize(static_cast<std::size_t>(pixels));
    if (peel) ctx.key_depth.resize(static_cast<std::size_t>(pixels));
    for (std::int64_t b = 0; b < mesh.images; ++b) {
      copy_flipped(at<const T>(mesh.pos) + mesh.pos_offset(b), mesh.vertices, &ctx.clip<T>());
      const auto [first, count] = mesh.range(b);
      raster::RasterParams<T> p;
      p.clip = ctx.clip<T>().data();
      p.num_vertices = mesh.vertices;
      p.tris = at<const std::int32_t>(mesh.tri) + 3 * first;
      p.num_tris = count;
      p.settings.width = width;
      p.settings.height = height;
      if (peel && peel->layers > 0) {
        p.floor_id = peel->floor_id.data() + b * pixels;
        p.floor_z = peel->floor_z.data() + b * pixels;
      }
      raster::rasterize_forward(p, ctx.tri_id.data(), ctx.uv<T>().data(), ctx.depth<T>().data(), nullptr,
                                peel ? ctx.key_depth.data() : nullptr);
      if (peel) {
        std::copy(ctx.tri_id.begin(), ctx.tri_id.end(), peel->floor_id.begin() + b * pixels);
        std::copy(ctx.key_depth.begin(), ctx.key_depth.end(), peel->floor_z.begin() + b * pixels);
      }
      raster::BarycentricGBufferParams<T> g{p.clip, mesh.vertices, at<const std::int32_t>(mesh.tri), mesh.triangles,
                                           width, height};
      raster::barycentric_gbuffer_forward(g, ctx.tri_id.data(), first, at<T>(rast) + 4 * pixels * b,
                                          db ? at<T>(db) + 4 * pixels * b : nullptr);
    }
  });
  if (peel) ++peel->layers;
}

void rasterize_backward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address grad_rast,
                        Address grad_db, Address grad_pos, int threads) {
  KernelCall call(threads);
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    std::vector<T>& grad = ctx.grad<T>();
    grad.assign(4 * static_cast<std::size_t>(mesh.vertices), T(0));
    for (std::int64_t b = 0; b < mesh.images; ++b) {
      copy_flipped(at<const T>(mesh.pos) + mesh.pos_offset(b), mesh.vertices, &ctx.clip<T>());
      raster::BarycentricGBufferParams<T> g{ctx.clip<T>().data(), mesh.vertices, at<const std::int32_t>(mesh.tri),
                                           mesh.triangles, width, height};
      raster::barycentric_gbuffer_backward(g, at<const T>(rast) + 4 * pixels * b,
                                           at<const T>(grad_rast) + 4 * pixels * b,
                                           grad_db ? at<const T>(grad_db) + 4 * pixels * b : nullptr, grad.data());
      // Instanced: each image has its own positions; range mode: all share one.
      if (mesh.instanced) {
        add_flipped(grad.data(), mesh.vertices, at<T>(grad_pos) + mesh.pos_offset(b));
        std::fill(grad.begin(), grad.end(), T(0));
      }
    }
    if (!mesh.instanced) add_flipped(grad.data(), mesh.vertices, at<T>(grad_pos));
  });
}

}  // namespace gr::python
