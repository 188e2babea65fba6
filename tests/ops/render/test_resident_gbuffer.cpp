// The ops' side of a G-buffer kept on a backend's device
// (ops/render/resident_gbuffer.h), on the CPU: a backend that makes its
// G-buffers with the CPU kernels, hands out handles and counts which calls
// get one. The ops pass the handle exactly while the G-buffer's tensors are
// those it was made with, and the results are the CPU's whatever they pass.
#include <catch2/catch.hpp>

#include <atomic>
#include <cstring>
#include <memory>
#include <utility>

#include "ops/ops.h"
#include "ops/render/resident_gbuffer.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/procedural.h"

using namespace gr;

namespace {

// Makes G-buffers with the CPU kernels; every other call counts and declines
// (the op then runs the CPU kernel).
class CountingBackend : public raster::RasterBackend {
 public:
  mutable std::atomic<int> made{0}, with_handle{0}, without_handle{0};
  std::string name() const override { return "counting"; }
  bool rasterize_forward(const raster::RasterParams<float>&, std::int32_t*, float*, float*, double*) const override {
    return false;
  }
  std::shared_ptr<const raster::DeviceGBuffer> rasterize_gbuffer(const raster::RasterParams<float>& p,
                                                                 std::int32_t* tri_id, float* uv, float* depth,
                                                                 float* db, double* key_depth) const override {
    raster::rasterize_forward(p, tri_id, static_cast<float*>(nullptr), static_cast<float*>(nullptr), nullptr,
                              key_depth);
    const raster::BarycentricGBufferParams<float> g{p.clip, p.num_vertices, p.tris, p.num_tris, p.settings.width,
                                                    p.settings.height, false};
    raster::barycentric_gbuffer_forward_planes(g, tri_id, uv, depth, static_cast<float>(raster::kBackgroundDepth), db);
    ++made;
    return std::make_shared<raster::DeviceGBuffer>();
  }
  bool count(const raster::DeviceGBuffer* resident) const {
    ++(resident ? with_handle : without_handle);
    return false;
  }
  bool interpolate_forward(const raster::DeviceGBuffer* resident, const raster::BarycentricInterpolateParams<float>&,
                           int, int, float*, float*, std::shared_ptr<const raster::DeviceForward>*) const override {
    return count(resident);
  }
  bool interpolate_backward(const raster::DeviceGBuffer* resident, const raster::BarycentricInterpolateParams<float>&,
                            int, int, const float*, const float*, const raster::BarycentricInterpolateGrads<float>&,
                            const raster::DeviceForward*) const override {
    return count(resident);
  }
  bool antialias_forward(const raster::DeviceGBuffer* resident, std::int64_t, const raster::AntialiasParams<float>&,
                         float*, std::shared_ptr<const raster::DeviceForward>*) const override {
    return count(resident);
  }
  bool gbuffer_backward(const raster::DeviceGBuffer* resident, const raster::BarycentricGBufferParams<float>&,
                        const float*, const float*, float*) const override {
    return count(resident);
  }
};

bool same_bits(const Tensor& a, const Tensor& b) {
  if (!a.defined() || !b.defined()) return a.defined() == b.defined();
  const std::size_t bytes = static_cast<std::size_t>(a.numel()) * (a.dtype() == DType::Float64 ? 8 : 4);
  return a.shape() == b.shape() && a.dtype() == b.dtype() &&
         std::memcmp(a.impl()->storage->data(), b.impl()->storage->data(), bytes) == 0;
}

struct Torus {
  Tensor clip, tris, colours;
  Torus() {
    const raster::Mesh m = raster::make_torus(24, 12);
    const std::int64_t n = m.positions.size(0);
    // Orthographic, the torus tilted into view: x, y, z in [-1, 1], w = 1.
    Tensor c = Tensor::zeros({n, 4});
    const float* p = m.positions.data<float>();
    float* d = c.data<float>();
    for (std::int64_t i = 0; i < n; ++i) {
      d[4 * i] = 0.7f * p[3 * i];
      d[4 * i + 1] = 0.6f * p[3 * i + 1] + 0.35f * p[3 * i + 2];
      d[4 * i + 2] = 0.5f * p[3 * i + 2] - 0.3f * p[3 * i + 1];
      d[4 * i + 3] = 1.0f;
    }
    clip = c;
    tris = m.triangles;
    colours = Tensor::uniform({n, 3}, 0, 1, 9);
  }
};

// rasterize -> interpolate_with_derivatives -> antialias -> loss -> backward;
// the G-buffer and dL/dclip.
std::pair<GBuffer, Tensor> chain(const Torus& t, const std::shared_ptr<const raster::RasterBackend>& backend) {
  Tensor clip = t.clip.detach().set_requires_grad();
  RasterizeOptions ro{40, 32};
  ro.derivatives = true;
  ro.backend = backend;
  const GBuffer gb = rasterize(clip, t.tris, ro);
  const InterpolatedWithDerivatives c = interpolate_with_derivatives(t.colours, gb, t.tris);
  const Tensor image = antialias(c.values, gb, clip, t.tris);
  backward(sum(image * image) + sum(c.d_dx) + sum(gb.depth * gb.depth));
  return {gb, clip.grad()};
}

}  // namespace

TEST_CASE("ops reading a G-buffer kept on a backend pass its handle and give the CPU's results",
          "[ops][rasterize][backend]") {
  const Torus t;
  const auto backend = std::make_shared<CountingBackend>();
  const auto [cpu_gb, cpu_grad] = chain(t, nullptr);
  const auto [gb, grad] = chain(t, backend);
  REQUIRE(gb.resident);
  CHECK(same_bits(gb.tri_id, cpu_gb.tri_id));
  CHECK(same_bits(gb.uv, cpu_gb.uv));
  CHECK(same_bits(gb.depth, cpu_gb.depth));
  CHECK(same_bits(gb.db, cpu_gb.db));
  CHECK(same_bits(grad, cpu_grad));
  CHECK(backend->made == 1);
  // interpolate and its adjoint, antialias (whose adjoint then runs on the CPU), the rasterize adjoint
  CHECK(backend->with_handle == 4);
  CHECK(backend->without_handle == 0);
}

TEST_CASE("ops pass no handle once the G-buffer's tensors were written in place or replaced",
          "[ops][rasterize][backend]") {
  const Torus t;
  const auto backend = std::make_shared<CountingBackend>();
  RasterizeOptions ro{40, 32};
  ro.backend = backend;
  GBuffer gb = rasterize(t.clip, t.tris, ro);
  REQUIRE(detail::resident_of(gb) != nullptr);
  SECTION("uv written in place") { gb.uv.data<float>(); }
  SECTION("tri_id written in place") { gb.tri_id.data<std::int32_t>(); }
  SECTION("depth replaced by a copy") { gb.depth = gb.depth.copy(); }
  SECTION("clip written in place") {
    Tensor clip = t.clip.copy();
    gb = rasterize(clip, t.tris, ro);
    clip.data<float>();
  }
  SECTION("db given to a G-buffer made without") { gb.db = Tensor::zeros({32, 40, 4}); }
  CHECK(detail::resident_of(gb) == nullptr);
  const int before = backend->without_handle;
  interpolate(t.colours, gb, t.tris);
  CHECK(backend->without_handle == before + 1);
}

TEST_CASE("a G-buffer read only through const access keeps its handle", "[ops][rasterize][backend]") {
  const Torus t;
  RasterizeOptions ro{40, 32};
  ro.backend = std::make_shared<CountingBackend>();
  const GBuffer gb = rasterize(t.clip, t.tris, ro);
  const GBuffer copy = gb;  // handles to the same tensors
  CHECK(std::as_const(copy.uv).data<float>() != nullptr);
  CHECK(detail::resident_of(copy) == detail::resident_of(gb));
  CHECK(detail::resident_of(copy) != nullptr);
}
