#include "python/src/rasterize.h"

#include <string>
#include <type_traits>

#include "autodiff/base/error.h"
#include "python/src/backend.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/mesh_checks.h"
#include "raster/rasterize.h"

namespace gr::python {

template <>
std::vector<float>& ImageScratch::buffer<float>(Buffer b) {
  return f_[b];
}
template <>
std::vector<double>& ImageScratch::buffer<double>(Buffer b) {
  return d_[b];
}

namespace {

// One image's G-buffer made on `backend` (rasterize_gbuffer: the CPU
// kernels' bits) into s's ids and planes and db (H*W*4 or null); returns its
// handle, or null when the backend makes none (the caller then runs the CPU
// kernels). Its outputs are written once the backend's deferred calls are.
std::shared_ptr<const raster::DeviceGBuffer> device_gbuffer(const raster::RasterBackend& backend,
                                                            const raster::RasterParams<float>& p, ImageScratch& s,
                                                            float* db, double* key_depth) {
  const std::int64_t pixels = static_cast<std::int64_t>(p.settings.width) * p.settings.height;
  std::vector<float>& uv = s.buffer<float>(ImageScratch::kUv);
  std::vector<float>& depth = s.buffer<float>(ImageScratch::kDepth);
  uv.resize(static_cast<std::size_t>(2 * pixels));
  depth.resize(static_cast<std::size_t>(pixels));
  return backend.rasterize_gbuffer(p, s.tri_id.data(), uv.data(), depth.data(), db, key_depth);
}

// device_gbuffer's ids and planes in s as barycentric_gbuffer_forward writes
// rast (H*W*4: ids offset by `first`, zeros on the background).
void rast_from_planes(ImageScratch& s, std::int64_t first, std::int64_t pixels, float* rast) {
  const std::vector<float>& uv = s.buffer<float>(ImageScratch::kUv);
  const std::vector<float>& depth = s.buffer<float>(ImageScratch::kDepth);
  for (std::int64_t q = 0; q < pixels; ++q) {
    const std::int32_t id = s.tri_id[static_cast<std::size_t>(q)];
    float* r = rast + 4 * q;
    r[0] = id ? uv[2 * q] : 0.0f;
    r[1] = id ? uv[2 * q + 1] : 0.0f;
    r[2] = id ? depth[q] : 0.0f;
    r[3] = id ? static_cast<float>(first + id) : 0.0f;
  }
}

}  // namespace

std::shared_ptr<DeviceGBuffers> rasterize_forward(Context& ctx, const pybind11::object& pos,
                                                  const pybind11::object& tri, Ranges ranges,
                                                  const pybind11::object& rast_, const pybind11::object& db_,
                                                  raster::DepthPeelState* peel, int threads) {
  const char* op = "rasterize";
  const Mesh mesh(pos, tri, ranges, op);
  const Array rast(rast_, op, "rast"), db(db_, op, "rast_db", true);
  check_rast_shape(rast, mesh.images, mesh.pos.elem(), op);
  raster::detail::check_image_size(rast.size(2), rast.size(1), op);
  db.same_elem(rast).shape(rast.shape());
  check_disjoint(op, {&rast, &db}, {&mesh.pos, &mesh.tri});
  const int height = static_cast<int>(rast.size(1)), width = static_cast<int>(rast.size(2));
  KernelCall call(threads);
  check_mesh(mesh, op);
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  // The layers of one peeler share its images and resolution (the Python
  // layer also refuses changed inputs; this guards the state's memory).
  if (peel) peel->begin_layer(mesh.images, width, height);
  ctx.reserve(mesh.images);
  std::shared_ptr<DeviceGBuffers> kept;
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    const raster::RasterBackend* backend = backend_for<T>(&ctx);
    if (backend) {
      keep_gbuffers(ctx, mesh.images);
      kept = std::make_shared<DeviceGBuffers>();
      kept->images.resize(static_cast<std::size_t>(mesh.images));
    }
    std::vector<char> on_device(static_cast<std::size_t>(mesh.images), 0);  // image b's G-buffer made there
    for_each_image_on(backend, mesh.images, [&](std::int64_t b) {
      ImageScratch& s = ctx.image(b);
      s.tri_id.resize(static_cast<std::size_t>(pixels));
      const auto [first, count] = mesh.range(b);
      raster::RasterParams<T> p;
      p.clip = mesh.positions<T>(b);
      p.num_vertices = mesh.vertices;
      p.tris = mesh.tris() + 3 * first;
      p.num_tris = count;
      p.settings.width = width;
      p.settings.height = height;
      p.settings.y_up = true;  // nvdiffrast's row 0 is the bottom row
      // A peeler's layer: only what lies behind the previous layer's key.
      double* key_depth = nullptr;
      if (peel) {
        p.floor_id = peel->floor_id(b);
        p.floor_z = peel->floor_z(b);
        key_depth = peel->key_z(b);
      }
      T* image_rast = rast.out<T>() + 4 * pixels * b;
      T* image_db = db ? db.out<T>() + 4 * pixels * b : nullptr;
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          auto handle = device_gbuffer(*backend, p, s, image_db, key_depth);
          on_device[static_cast<std::size_t>(b)] = counted(ctx, handle != nullptr);
          // The copy drew the range's triangles, its ids numbered from 1 in it.
          kept->images[static_cast<std::size_t>(b)] = {std::move(handle), first, count};
          if (on_device[static_cast<std::size_t>(b)]) return;
        }
      // The coverage, then the values (barycentric_gbuffer_forward).
      T* const no_values = nullptr;
      raster::rasterize_forward(p, s.tri_id.data(), no_values, no_values, nullptr, key_depth);
      const raster::BarycentricGBufferParams<T> g{p.clip, mesh.vertices, mesh.tris(), mesh.triangles, width, height,
                                                  true};
      raster::barycentric_gbuffer_forward(g, s.tri_id.data(), first, image_rast, image_db);
    }, [&](std::int64_t b) {  // once the device's calls have written their outputs
      ImageScratch& s = ctx.image(b);
      if constexpr (std::is_same_v<T, float>)
        if (on_device[static_cast<std::size_t>(b)])
          rast_from_planes(s, mesh.range(b).first, pixels, rast.out<T>() + 4 * pixels * b);
      if (peel) peel->keep_ids(b, s.tri_id.data());
    });
  });
  if (peel) peel->end_layer();
  return kept;
}

void rasterize_backward(Context& ctx, const pybind11::object& pos, const pybind11::object& tri, Ranges ranges,
                        const pybind11::object& rast_, const pybind11::object& grad_rast_,
                        const pybind11::object& grad_db_, const pybind11::object& grad_pos_, int threads,
                        const DeviceGBuffers* kept) {
  const char* op = "rasterize backward";
  const Mesh mesh(pos, tri, ranges, op);
  const Array rast(rast_, op, "rast"), grad_rast(grad_rast_, op, "grad_rast"), grad_db(grad_db_, op, "grad_db", true),
      grad_pos(grad_pos_, op, "grad_pos");
  check_rast_shape(rast, mesh.images, mesh.pos.elem(), op);
  grad_rast.same_elem(rast).shape(rast.shape());
  grad_db.same_elem(rast).shape(rast.shape());
  grad_pos.same_elem(mesh.pos).shape(mesh.pos.shape());
  check_disjoint(op, {&grad_pos}, {&mesh.pos, &mesh.tri, &rast, &grad_rast, &grad_db});
  const int height = static_cast<int>(rast.size(1)), width = static_cast<int>(rast.size(2));
  KernelCall call(threads);
  check_mesh(mesh, op);
  const std::int64_t pixels = static_cast<std::int64_t>(height) * width;
  check_kept(kept, mesh.images, op);
  ctx.reserve(mesh.images);
  dispatch(mesh.f64, [&](auto tag) {
    using T = decltype(tag);
    raster::detail::check_rast_ids(rast.in<T>(), mesh.images * pixels, mesh.triangles, "rast", op);
    // Instanced images own their positions and add straight into grad_pos;
    // range-mode images share them: each in its own buffer, summed in image
    // order. On the context's device (float32), image by image.
    const raster::RasterBackend* backend = backend_for<T>(&ctx);
    for_each_image_on(backend, mesh.images, [&](std::int64_t b) {
      ImageScratch& s = ctx.image(b);
      T* out = grad_pos.out<T>() + mesh.pos_offset(b);
      if (!mesh.instanced) {
        std::vector<T>& grad = s.buffer<T>(ImageScratch::kGrad);
        grad.assign(4 * static_cast<std::size_t>(mesh.vertices), T(0));
        out = grad.data();
      }
      raster::BarycentricGBufferParams<T> g{mesh.positions<T>(b), mesh.vertices, mesh.tris(), mesh.triangles,
                                            width, height, true};
      const T* image_rast = rast.in<T>() + 4 * pixels * b;
      const T* g_rast = grad_rast.in<T>() + 4 * pixels * b;
      const T* g_db = grad_db ? grad_db.in<T>() + 4 * pixels * b : nullptr;
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          // The device reads the coverage as int32 ids (rast's id channel),
          // as its copy drew the image (a range's triangles, ids local to it).
          rast_ids(image_rast, pixels, &s.tri_id);
          const raster::ImageOnDevice on = image_on_device(kept, b, g.tris, g.num_tris, s.tri_id.data(), pixels, false);
          raster::BarycentricGBufferParams<float> pb = g;
          pb.tris = on.tris;
          pb.num_tris = on.num_tris;
          pb.tri_id = on.ids();
          if (counted(ctx, backend->gbuffer_backward(on.device, pb, g_rast, g_db, out)))
            return;
        }
      raster::barycentric_gbuffer_backward(g, image_rast, g_rast, g_db, out);
    });
    if (!mesh.instanced)
      raster::sum_in_image_order(ctx.grads<T>(mesh.images).data(), mesh.images, 4 * mesh.vertices, grad_pos.out<T>());
  });
}

}  // namespace gr::python
