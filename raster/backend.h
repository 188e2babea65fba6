// Where the raster kernels run: the CPU (no backend) or another device
// (raster/vulkan/backend.h gives a Vulkan one), the ops' execution context
// (RasterizeOptions::backend, which the G-buffer keeps for interpolate,
// antialias and the rasterize adjoint; TextureOptions::backend,
// CubeTextureOptions::backend). A backend gives rasterize_forward's coverage
// bit for bit; interpolate, antialias and the G-buffer adjoint the CPU
// kernels' values within 1e-6 and gradients within 1e-5 of the largest;
// texture and cube-map lookups the CPU kernel's samples (within an ulp of
// float) and gradients (within 1e-5 of the largest).
//
// Residency: a backend may make the whole G-buffer on its device and keep it
// there (rasterize_gbuffer, which returns a DeviceGBuffer handle); the
// interpolate, antialias and G-buffer adjoint calls given that handle read the
// device's copy instead of uploading the arrays, while the backend still holds
// it, and upload the arrays as the plain calls do otherwise. Results are the
// same either way (the arrays are the device's copy, downloaded). Likewise a
// texture: texture_forward / texture_backward with a DeviceTexture handle
// keep the texels they read (the levels too) on the device, and read that
// copy at the next call given the handle while the backend still holds it;
// cube_texture_forward / cube_texture_backward with a handle likewise (the 6
// faces and their levels).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>

#include "raster/antialias.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/barycentric_interpolate.h"
#include "raster/cube_texture.h"
#include "raster/rasterize.h"
#include "raster/texture.h"

namespace gr::raster {

// A G-buffer kept on a backend's device (RasterBackend::rasterize_gbuffer):
// opaque to the caller, who holds it as long as it keeps the G-buffer's
// arrays unchanged. The backend may let the device's copy go at any time (to
// make another G-buffer); the handle then only costs an upload.
class DeviceGBuffer {
 public:
  virtual ~DeviceGBuffer() = default;
};

// A texture's texels kept on a backend's device (the texture calls with a
// handle): opaque to the caller, who hands it back only while the texels the
// copy was made from are unchanged. The backend may let the copy go at any
// time; the handle then only costs an upload.
class DeviceTexture {
 public:
  virtual ~DeviceTexture() = default;
};

// What a forward call left on a backend's device for its adjoint (antialias's
// pairs and image, interpolate's attributes), from antialias_forward or
// interpolate_forward with a handle: opaque to the caller, who hands it to
// that call's adjoint only, with the forward's inputs unchanged. The adjoint
// then reads it instead of running the forward again, while the device still
// holds it (another call of the same op or a new G-buffer on the same copy
// lets it go; the adjoint then reruns the forward, with the same results).
class DeviceForward {
 public:
  virtual ~DeviceForward() = default;
};

class RasterBackend {
 public:
  virtual ~RasterBackend() = default;
  // Deferred calls (DeferredCalls below holds them open): between
  // begin_deferred and end_deferred, the G-buffer chain's calls made on
  // this thread (rasterize_gbuffer, interpolate_*, antialias_*,
  // gbuffer_backward) may return before they have written their outputs; the
  // backend writes them, in call order, by the end (end_deferred(true)), or
  // drops them (false: the caller is unwinding). Inputs are read during the
  // call; handles are valid at once. Other threads' calls wait for the end.
  // The defaults defer nothing.
  virtual void begin_deferred() const {}
  virtual void end_deferred(bool /*write_outputs*/) const {}
  // e.g. "vulkan: NVIDIA H200".
  virtual std::string name() const = 0;
  // rasterize_forward(p, tri_id, uv, depth, nullptr, key_depth) (depth
  // peeling included) for what the backend covers; false when it does not
  // (the caller then runs the CPU kernel). p is validated; key_depth may be null.
  virtual bool rasterize_forward(const RasterParams<float>& p, std::int32_t* tri_id, float* uv, float* depth,
                                 double* key_depth) const = 0;
  // rasterize_forward's coverage tri_id (H x W) and, for it,
  // barycentric_gbuffer_forward_planes' values (uv H x W x 2, depth H x W with
  // kBackgroundDepth on the background, db H x W x 4 when not null), bit for
  // bit the CPU kernels', made on the device, downloaded into these arrays and
  // kept there: returns its handle, or null when the backend does not make
  // G-buffers (the caller then runs the CPU kernels; the arrays may have been
  // written). p is validated; depth peeling and key_depth (may be null) as in
  // rasterize_forward.
  virtual std::shared_ptr<const DeviceGBuffer> rasterize_gbuffer(const RasterParams<float>& /*p*/,
                                                                 std::int32_t* /*tri_id*/, float* /*uv*/,
                                                                 float* /*depth*/, float* /*db*/,
                                                                 double* /*key_depth*/) const {
    return nullptr;
  }
  // texture_forward(p, out) / texture_backward(p, grad_out, grads) (raster/texture.h,
  // ACCUMULATED like it) for what the backend covers; false when it does not
  // (the caller then runs the CPU kernel). p is validated by the op.
  virtual bool texture_forward(const TextureParams<float>& /*p*/, float* /*out*/) const { return false; }
  virtual bool texture_backward(const TextureParams<float>& /*p*/, const float* /*grad_out*/,
                                const TextureGrads<float>& /*grads*/) const {
    return false;
  }
  // True when texture_forward / texture_backward take p.pyramid null for the
  // mip levels the caller would build with mip_build (not the user's levels)
  // and build them on the device, mip_build's bits (they then cover every
  // float32 call: they never return false); the cube-map calls likewise
  // (cube_mip_build's levels).
  virtual bool builds_mip_levels() const { return false; }
  // The same two keeping the texels read on the device. kept, in: the handle
  // an earlier call gave back while p's texels (p.tex and the levels read)
  // are still those it read (the caller vouches: the same arrays, unwritten
  // since), else null; out: the handle of the copy this call read (null:
  // none kept). Results as the calls above (the defaults just call them).
  virtual bool texture_forward(const TextureParams<float>& p, float* out,
                               std::shared_ptr<const DeviceTexture>& kept) const {
    kept = nullptr;
    return texture_forward(p, out);
  }
  virtual bool texture_backward(const TextureParams<float>& p, const float* grad_out, const TextureGrads<float>& grads,
                                std::shared_ptr<const DeviceTexture>& kept) const {
    kept = nullptr;
    return texture_backward(p, grad_out, grads);
  }
  // cube_texture_forward / cube_texture_backward (raster/cube_texture.h),
  // likewise: false when the backend does not cover them. With
  // builds_mip_levels, p.pyramid null (the levels cube_mip_build would make)
  // is built on the device too, cube_mip_build's bits.
  virtual bool cube_texture_forward(const CubeTextureParams<float>& /*p*/, float* /*out*/) const { return false; }
  virtual bool cube_texture_backward(const CubeTextureParams<float>& /*p*/, const float* /*grad_out*/,
                                     const CubeTextureGrads<float>& /*grads*/) const {
    return false;
  }
  // The same two keeping the 6 faces (and the levels read) on the device, as
  // texture_forward / texture_backward with `kept` do (the defaults just call
  // the two above).
  virtual bool cube_texture_forward(const CubeTextureParams<float>& p, float* out,
                                    std::shared_ptr<const DeviceTexture>& kept) const {
    kept = nullptr;
    return cube_texture_forward(p, out);
  }
  virtual bool cube_texture_backward(const CubeTextureParams<float>& p, const float* grad_out,
                                     const CubeTextureGrads<float>& grads,
                                     std::shared_ptr<const DeviceTexture>& kept) const {
    kept = nullptr;
    return cube_texture_backward(p, grad_out, grads);
  }
  // The ops' G-buffer chain, float32, one image of width x height pixels
  // (the ops pass the G-buffer's arrays). Each gives the CPU kernel's results
  // within issue 33's tolerances (values 1e-6, gradients 1e-5 relative to the
  // largest), deterministic, or returns false (the caller then runs the CPU
  // kernel). Adjoints ACCUMULATE (+=). `resident`: the handle rasterize_gbuffer
  // gave for the G-buffer p describes, while p's arrays are that call's and
  // unchanged since (the caller vouches), else null. A backend reads its
  // device's copy where it still holds it, else uploads p's arrays.
  // barycentric_interpolate_forward / _backward (p.tri_id and p.rast with
  // its stride given; p.groups is the CPU's and ignored):
  // kept (forward, may be null) and forward (adjoint, may be null): as
  // antialias's below.
  virtual bool interpolate_forward(const DeviceGBuffer* /*resident*/, const BarycentricInterpolateParams<float>& /*p*/,
                                   int /*width*/, int /*height*/, float* /*out*/, float* /*out_da*/,
                                   std::shared_ptr<const DeviceForward>* kept) const {
    if (kept) *kept = nullptr;
    return false;
  }
  virtual bool interpolate_backward(const DeviceGBuffer* /*resident*/, const BarycentricInterpolateParams<float>& /*p*/,
                                    int /*width*/, int /*height*/, const float* /*grad_out*/,
                                    const float* /*grad_da*/, const BarycentricInterpolateGrads<float>& /*grads*/,
                                    const DeviceForward* /*forward*/) const {
    return false;
  }
  // antialias_forward / antialias_backward (raster/antialias.h), or with
  // p.visibility visibility_antialias_forward / _backward
  // (raster/visibility_antialias.h); the adjoint takes the forward's whole p
  // (a backend may recompute the pairs) instead of its pairs. p holds the
  // whole triangle list (the topology's) and the host's ids; resident_first:
  // the row of p.tris where the triangles `resident` drew start (a range
  // mode image's copy, drawn from rows resident_first.. of p.tris, numbers
  // its ids from 1 in its range: the device adds resident_first; 0 for a
  // copy of the whole list or none). kept (forward, may be null): receives
  // the handle of what the device keeps for the adjoint, or null; the
  // adjoint of that very call may pass it as `forward` (else null).
  virtual bool antialias_forward(const DeviceGBuffer* /*resident*/, std::int64_t /*resident_first*/,
                                 const AntialiasParams<float>& /*p*/, float* /*out*/,
                                 std::shared_ptr<const DeviceForward>* kept) const {
    if (kept) *kept = nullptr;
    return false;
  }
  virtual bool antialias_backward(const DeviceGBuffer* /*resident*/, std::int64_t /*resident_first*/,
                                  const AntialiasParams<float>& /*p*/, const float* /*grad_out*/,
                                  const AntialiasGrads<float>& /*grads*/,
                                  const DeviceForward* /*forward*/) const {
    return false;
  }
  // barycentric_gbuffer_backward (raster/barycentric_gbuffer.h) for
  // grad_rast (H x W x 4: u, v, z/w; the id channel ignored) and grad_db
  // (H x W x 4, or null), into grad_clip (N x 4).
  virtual bool gbuffer_backward(const DeviceGBuffer* /*resident*/, const BarycentricGBufferParams<float>& /*p*/,
                                const float* /*grad_rast*/, const float* /*grad_db*/, float* /*grad_clip*/) const {
    return false;
  }
};

// Holds a backend's deferred calls open (RasterBackend::begin_deferred) from
// construction to finish(), after which their outputs are written; e.g. a
// batch's images, so that a device runs one image while the host prepares
// the next. Destroyed without finish() (an exception), it waits for the
// device and writes nothing. backend may be null (nothing deferred).
class DeferredCalls {
 public:
  explicit DeferredCalls(const RasterBackend* backend) : backend_(backend) {
    if (backend_) backend_->begin_deferred();
  }
  ~DeferredCalls() {
    if (backend_) try {
        backend_->end_deferred(false);
      } catch (...) {
      }
  }
  DeferredCalls(const DeferredCalls&) = delete;
  DeferredCalls& operator=(const DeferredCalls&) = delete;
  // Writes every deferred call's outputs; the calls after it run at once.
  void finish() {
    const RasterBackend* b = backend_;
    backend_ = nullptr;
    if (b) b->end_deferred(true);
  }

 private:
  const RasterBackend* backend_;
};

// rasterize_forward (raster/rasterize.h) on `backend` where it covers p
// (float32 clip positions), else on the CPU; stats only from the CPU kernel.
template <class T>
void rasterize_forward_on(const RasterBackend* backend, const RasterParams<T>& p, std::int32_t* tri_id, T* uv,
                          T* depth, RasterStats* stats = nullptr, double* key_depth = nullptr) {
  if constexpr (std::is_same_v<T, float>)
    if (backend && backend->rasterize_forward(p, tri_id, uv, depth, key_depth)) return;
  rasterize_forward(p, tri_id, uv, depth, stats, key_depth);
}

}  // namespace gr::raster
