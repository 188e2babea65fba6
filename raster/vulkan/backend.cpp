// The Vulkan RasterBackend: rasterize_forward through the device's own Frame,
// the texture lookups through raster/vulkan/texture.h, the cube maps'
// through raster/vulkan/cube_texture.h; the G-buffer chain (rasterize_gbuffer,
// interpolate, antialias, the G-buffer adjoint) through a FramePool: each
// G-buffer it makes stays in a frame tagged with the handle's serial, which
// the calls given that handle read; the others load the ops' G-buffer into
// one scratch frame outside the pool (Frame::load_gbuffer), so an upload never
// lets a kept G-buffer go.
#include "raster/vulkan/backend.h"

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/vulkan/cube_texture.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/frame_pool.h"
#include "raster/vulkan/internal/context.h"
#include "raster/vulkan/rasterize.h"
#include "raster/vulkan/texture.h"

namespace gr::vulkan {
namespace {

// G-buffer serials, unique in the process: a handle outliving its backend
// never matches a frame of another backend made at the same address.
std::atomic<std::uint64_t> g_serial{0};

// A G-buffer a VulkanBackend keeps: its frame's tag in the backend's pool and
// what the calls on it must describe.
struct VulkanGBuffer final : raster::DeviceGBuffer {
  std::uint64_t serial = 0;
  int width = 0, height = 0;
  std::int64_t num_vertices = 0, num_tris = 0;
  bool y_up = false, derivatives = false;
};

// What a call on a G-buffer describes, to match against the kept one; y_up
// only where the call reads the clip positions (interpolate reads the
// G-buffer's values alone, the same either way).
struct Described {
  int width, height;
  std::int64_t num_vertices, num_tris;
  bool reads_clip, y_up, needs_db;
};

void check_pixels(const raster::BarycentricInterpolateParams<float>& p, int width, int height) {
  if (std::int64_t(width) * height != p.pixels)
    throw ValueError("vulkan interpolate: " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels, but the parameters hold " + std::to_string(p.pixels));
}

// What a forward left in its frame for its adjoint (Frame::antialias_serial,
// Frame::interpolate_serial).
struct VulkanForward final : raster::DeviceForward {
  explicit VulkanForward(std::uint64_t serial) : serial(serial) {}
  std::uint64_t serial;
};

// Texels a VulkanBackend's device keeps (texture.h's KeptTexels serial).
struct VulkanTexture final : raster::DeviceTexture {
  explicit VulkanTexture(std::uint64_t serial) : serial(serial) {}
  std::uint64_t serial;
};

// Runs call(kept) with kept's serial (0 when null or not a VulkanTexture); kept
// becomes the handle of the copy the call read, or null.
template <class Call>
void with_kept(std::shared_ptr<const raster::DeviceTexture>& kept, Call call) {
  const auto* v = dynamic_cast<const VulkanTexture*>(kept.get());
  KeptTexels k{v ? v->serial : 0};
  call(&k);
  if (!k.serial)
    kept = nullptr;
  else if (!v || v->serial != k.serial)
    kept = std::make_shared<VulkanTexture>(k.serial);
}

class VulkanBackend : public raster::RasterBackend {
 public:
  VulkanBackend(std::shared_ptr<Device> device, int frames, bool deferred_calls)
      : device_(device), pool_(device, frames), deferred_calls_(deferred_calls) {}
  std::string name() const override { return "vulkan: " + device_->info().name; }
  bool rasterize_forward(const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv, float* depth,
                         double* key_depth) const override {
    vulkan::rasterize_forward(*device_, p, tri_id, uv, depth, {}, nullptr, key_depth);
    return true;
  }
  std::shared_ptr<const raster::DeviceGBuffer> rasterize_gbuffer(const raster::RasterParams<float>& p,
                                                                 std::int32_t* tri_id, float* uv, float* depth,
                                                                 float* db, double* key_depth) const override {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    GpuRasterOptions options;
    options.derivatives = db != nullptr;
    const std::int64_t px = std::int64_t(p.settings.width) * p.settings.height;
    auto rast = std::make_shared<std::vector<float>>(static_cast<std::size_t>(4 * px));
    Frame& f = pool_.take();
    f.rasterize(p, options, tri_id, rast->data(), db, key_depth);
    // rast (u, v, z/w, id) as the op's planes, the background's depth the far
    // plane (barycentric_gbuffer_forward_planes), once the call has written it.
    after_calls([rast, px, tri_id, uv, depth] {
      const float background = static_cast<float>(raster::kBackgroundDepth);
      const float* r = rast->data();
      for (std::int64_t q = 0; q < px; ++q) {
        if (uv) uv[2 * q] = r[4 * q], uv[2 * q + 1] = r[4 * q + 1];
        if (depth) depth[q] = tri_id[q] != 0 ? r[4 * q + 2] : background;
      }
    });
    auto kept = std::make_shared<VulkanGBuffer>();
    kept->serial = ++g_serial;
    kept->width = p.settings.width;
    kept->height = p.settings.height;
    kept->num_vertices = p.num_vertices;
    kept->num_tris = p.num_tris;
    kept->y_up = p.settings.y_up;
    kept->derivatives = options.derivatives;
    pool_.tag(f, kept->serial, kept);
    ++stats_.gbuffers;
    return kept;
  }
  bool texture_forward(const raster::TextureParams<float>& p, float* out) const override {
    vulkan::texture_forward(*device_, p, out);
    return true;
  }
  bool texture_backward(const raster::TextureParams<float>& p, const float* grad_out,
                        const raster::TextureGrads<float>& grads) const override {
    vulkan::texture_backward(*device_, p, grad_out, grads);
    return true;
  }
  bool builds_mip_levels() const override { return true; }
  bool texture_forward(const raster::TextureParams<float>& p, float* out,
                       std::shared_ptr<const raster::DeviceTexture>& kept) const override {
    with_kept(kept, [&](KeptTexels* k) { vulkan::texture_forward(*device_, p, out, k); });
    return true;
  }
  bool texture_backward(const raster::TextureParams<float>& p, const float* grad_out,
                        const raster::TextureGrads<float>& grads,
                        std::shared_ptr<const raster::DeviceTexture>& kept) const override {
    with_kept(kept, [&](KeptTexels* k) { vulkan::texture_backward(*device_, p, grad_out, grads, k); });
    return true;
  }
  bool cube_texture_forward(const raster::CubeTextureParams<float>& p, float* out) const override {
    vulkan::cube_texture_forward(*device_, p, out);
    return true;
  }
  bool cube_texture_backward(const raster::CubeTextureParams<float>& p, const float* grad_out,
                             const raster::CubeTextureGrads<float>& grads) const override {
    vulkan::cube_texture_backward(*device_, p, grad_out, grads);
    return true;
  }
  bool cube_texture_forward(const raster::CubeTextureParams<float>& p, float* out,
                            std::shared_ptr<const raster::DeviceTexture>& kept) const override {
    with_kept(kept, [&](KeptTexels* k) { vulkan::cube_texture_forward(*device_, p, out, k); });
    return true;
  }
  bool cube_texture_backward(const raster::CubeTextureParams<float>& p, const float* grad_out,
                             const raster::CubeTextureGrads<float>& grads,
                             std::shared_ptr<const raster::DeviceTexture>& kept) const override {
    with_kept(kept, [&](KeptTexels* k) { vulkan::cube_texture_backward(*device_, p, grad_out, grads, k); });
    return true;
  }

  bool interpolate_forward(const raster::DeviceGBuffer* resident, const raster::BarycentricInterpolateParams<float>& p,
                           int width, int height, float* out, float* out_da,
                           std::shared_ptr<const raster::DeviceForward>* kept) const override {
    if (!p.tri_id) return false;
    check_pixels(p, width, height);
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    Frame& f = for_interpolate(resident, p, width, height);
    f.interpolate(p.attr, p.channels, out, p.diff, p.num_diff, out_da);
    if (kept) *kept = std::make_shared<VulkanForward>(f.interpolate_serial());
    return true;
  }
  bool interpolate_backward(const raster::DeviceGBuffer* resident, const raster::BarycentricInterpolateParams<float>& p,
                            int width, int height, const float* grad_out, const float* grad_da,
                            const raster::BarycentricInterpolateGrads<float>& grads,
                            const raster::DeviceForward* forward) const override {
    if (!p.tri_id) return false;
    check_pixels(p, width, height);
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    Frame& f = for_interpolate(resident, p, width, height);
    // The adjoint reads the frame's last interpolate: the forward's while its
    // frame still holds it (the caller vouches that p is that forward's), else this one again.
    const auto* mine = dynamic_cast<const VulkanForward*>(forward);
    if (mine && mine->serial == f.interpolate_serial())
      ++stats_.interpolate_reused;
    else
      f.interpolate(p.attr, p.channels, nullptr, p.diff, p.num_diff, nullptr);
    // The G-buffer's gradient comes back as rast (H x W x 4) and rast_db;
    // its u, v go to grads.rast at the caller's stride, as the CPU adds them.
    const std::size_t plane = static_cast<std::size_t>(p.pixels) * 4;
    auto g_rast = std::make_shared<std::vector<float>>(grads.rast ? plane : 0, 0.0f);
    f.interpolate_backward(grad_out, grad_da, grads.attr, grads.rast ? g_rast->data() : nullptr, grads.rast_db);
    if (grads.rast)
      after_calls([g_rast, to = grads.rast, stride = p.rast_stride, pixels = p.pixels] {
        for (std::int64_t q = 0; q < pixels; ++q) {
          to[stride * q] += (*g_rast)[4 * q];
          to[stride * q + 1] += (*g_rast)[4 * q + 1];
        }
      });
    return true;
  }
  bool antialias_forward(const raster::DeviceGBuffer* resident, std::int64_t resident_first,
                         const raster::AntialiasParams<float>& p, float* out,
                         std::shared_ptr<const raster::DeviceForward>* kept) const override {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    WholeTriangles whole;
    Frame& f = for_antialias(resident, resident_first, p, &whole);
    const Uploads before = f.topology_uploads();
    f.antialias(p.image, p.channels, out, p.topology, p.visibility, &whole);
    count_topology_uploads(f, before);
    if (kept) *kept = std::make_shared<VulkanForward>(f.antialias_serial());
    return true;
  }
  bool antialias_backward(const raster::DeviceGBuffer* resident, std::int64_t resident_first,
                          const raster::AntialiasParams<float>& p, const float* grad_out,
                          const raster::AntialiasGrads<float>& grads,
                          const raster::DeviceForward* forward) const override {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    WholeTriangles whole;
    Frame& f = for_antialias(resident, resident_first, p, &whole);
    // The forward's pairs while its frame still holds them (the caller vouches
    // that p is that forward's), else the pairs again, on the device.
    const auto* mine = dynamic_cast<const VulkanForward*>(forward);
    if (mine && mine->serial == f.antialias_serial()) {
      ++stats_.antialias_reused;
    } else {
      const Uploads before = f.topology_uploads();
      f.antialias(p.image, p.channels, nullptr, p.topology, p.visibility, &whole);
      count_topology_uploads(f, before);
    }
    f.antialias_backward(grad_out, grads.image, grads.clip);
    return true;
  }
  bool gbuffer_backward(const raster::DeviceGBuffer* resident, const raster::BarycentricGBufferParams<float>& p,
                        const float* grad_rast, const float* grad_db, float* grad_clip) const override {
    if (!p.tri_id) return false;
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    Frame* f =
        kept_frame(resident, {p.width, p.height, p.num_vertices, p.num_tris, true, p.y_up, grad_db != nullptr});
    if (!f) {
      raster::RasterParams<float> rp{p.clip, p.num_vertices, p.tris, p.num_tris, {p.width, p.height}};
      GpuRasterOptions options;
      options.y_up = p.y_up;
      options.derivatives = grad_db != nullptr;
      f = &upload_frame();
      f->load_gbuffer(rp, options, p.tri_id, nullptr, 2, nullptr, nullptr);
    }
    // The ops carry the G-buffer's gradient on the host (grad_rast, grad_db):
    // what interpolate adjoints may have left on the device is not added again.
    f->discard_gbuffer_gradient();
    f->rasterize_backward(grad_rast, grad_db, grad_clip);
    return true;
  }

  void begin_deferred() const override {
    if (!deferred_calls_) return;
    mutex_.lock();  // held until end_deferred: other threads' calls wait
    try {
      std::lock_guard<std::mutex> lock(device_->impl().mutex);
      device_->impl().begin_deferring();
      if (++deferring_ == 1) deferred_before_ = device_->impl().deferred_submissions();
    } catch (...) {
      mutex_.unlock();
      throw;
    }
  }
  void end_deferred(bool write_outputs) const override {
    if (!deferred_calls_) return;
    struct Unlock {
      std::recursive_mutex& m;
      ~Unlock() { m.unlock(); }
    } unlock{mutex_};
    Device::Impl& dev = device_->impl();
    std::lock_guard<std::mutex> lock(dev.mutex);
    if (--deferring_ == 0) stats_.deferred_calls += dev.deferred_submissions() - deferred_before_;
    dev.end_deferring();
    dev.complete(write_outputs);
  }

  ResidencyStats stats() const {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    ResidencyStats s = stats_;
    s.frames = pool_.frames();
    Uploads tris = pool_.triangle_uploads();
    if (scratch_) {
      const Uploads u = scratch_->triangle_uploads();
      tris.uploads += u.uploads;
      tris.bytes += u.bytes;
    }
    s.triangle_uploads = tris.uploads;
    s.triangle_bytes = tris.bytes;
    return s;
  }
  void reserve_frames(int frames) const {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    pool_.reserve(frames);
  }

 private:
  // The frame that holds `resident`'s G-buffer (may be null), if this backend made it, still
  // keeps it and it is the one `d` describes; else null (the caller uploads).
  Frame* kept_frame(const raster::DeviceGBuffer* resident, const Described& d) const {
    const auto* g = dynamic_cast<const VulkanGBuffer*>(resident);
    if (!g || g->width != d.width || g->height != d.height ||
        g->num_vertices != d.num_vertices || g->num_tris != d.num_tris || (d.reads_clip && g->y_up != d.y_up) ||
        (d.needs_db && !g->derivatives))
      return nullptr;
    Frame* f = pool_.find(g->serial);
    if (f) ++stats_.resident_calls;
    return f;
  }
  // Interpolation reads no clip positions: an uploaded frame gets the
  // triangles and as many (unread) vertices as the attributes have rows.
  Frame& for_interpolate(const raster::DeviceGBuffer* resident, const raster::BarycentricInterpolateParams<float>& p,
                         int width, int height) const {
    if (Frame* f = kept_frame(resident, {width, height, p.num_vertices, p.num_tris, false, false, p.num_diff > 0}))
      return *f;
    zero_clip_.assign(static_cast<std::size_t>(4 * p.num_vertices), 0.0f);
    raster::RasterParams<float> rp{zero_clip_.data(), p.num_vertices, p.tris, p.num_tris, {width, height}};
    GpuRasterOptions options;
    options.derivatives = p.num_diff > 0;
    Frame& f = upload_frame();
    f.load_gbuffer(rp, options, p.tri_id, p.rast, static_cast<int>(p.rast_stride), nullptr,
                   p.num_diff > 0 ? p.rast_db : nullptr);
    return f;
  }
  // The frame for an antialias on p (its whole list and the host's ids) and
  // *whole: p's list, of which `resident` (a range mode image's copy) drew
  // rows first.. (the frame reads the whole list, the copy's ids offset by
  // first); an uploaded frame has p's list itself (first 0).
  Frame& for_antialias(const raster::DeviceGBuffer* resident, std::int64_t first,
                       const raster::AntialiasParams<float>& p, WholeTriangles* whole) const {
    *whole = {p.tris, p.num_tris, 0};
    const auto* g = dynamic_cast<const VulkanGBuffer*>(resident);
    if (g && first >= 0 && first <= p.num_tris - g->num_tris)
      if (Frame* f = kept_frame(resident, {p.width, p.height, p.num_vertices, g->num_tris, true, p.y_up, false})) {
        whole->first = first;
        return *f;
      }
    raster::RasterParams<float> rp{p.clip, p.num_vertices, p.tris, p.num_tris, {p.width, p.height}};
    GpuRasterOptions options;
    options.y_up = p.y_up;
    Frame& f = upload_frame();
    f.load_gbuffer(rp, options, p.tri_id, nullptr, 2, p.depth, nullptr);
    return f;
  }
  // Runs `finish` after the calls before it have written their outputs (at
  // once, unless they are deferred).
  void after_calls(std::function<void()> finish) const {
    std::lock_guard<std::mutex> lock(device_->impl().mutex);
    device_->impl().then(std::move(finish));
  }
  // Adds what f's antialias uploaded of the edge topology since `before`.
  void count_topology_uploads(const Frame& f, const Uploads& before) const {
    const Uploads now = f.topology_uploads();
    stats_.topology_uploads += now.uploads - before.uploads;
    stats_.topology_bytes += now.bytes - before.bytes;
  }
  // The frame a call without a kept G-buffer loads it into (counted as an upload).
  Frame& upload_frame() const {
    if (!scratch_) scratch_ = std::make_unique<Frame>(device_);
    ++stats_.uploads;
    return *scratch_;
  }

  std::shared_ptr<Device> device_;
  // The G-buffer chain's frames and what they did; one call at a time (and
  // one thread from begin_deferred to end_deferred).
  mutable std::recursive_mutex mutex_;
  mutable FramePool pool_;
  mutable std::unique_ptr<Frame> scratch_;  // made at the first upload
  mutable ResidencyStats stats_;
  mutable std::vector<float> zero_clip_;
  const bool deferred_calls_;
  mutable int deferring_ = 0;  // begin_deferred calls not yet ended
  mutable std::int64_t deferred_before_ = 0;  // the device's deferred submissions at the first
};

}  // namespace

std::shared_ptr<const raster::RasterBackend> raster_backend(std::shared_ptr<Device> device, int frames,
                                                            bool deferred_calls) {
  if (!device) throw ValueError("vulkan raster_backend: no device");
  if (frames < 1) throw ValueError("vulkan raster_backend: frames must be at least 1, got " + std::to_string(frames));
  return std::make_shared<VulkanBackend>(std::move(device), frames, deferred_calls);
}

ResidencyStats residency_stats(const raster::RasterBackend& backend) {
  const auto* vulkan = dynamic_cast<const VulkanBackend*>(&backend);
  if (!vulkan) throw ValueError("vulkan residency_stats: '" + backend.name() + "' is not a vulkan raster_backend");
  return vulkan->stats();
}

void reserve_frames(const raster::RasterBackend& backend, int frames) {
  const auto* vulkan = dynamic_cast<const VulkanBackend*>(&backend);
  if (!vulkan) throw ValueError("vulkan reserve_frames: '" + backend.name() + "' is not a vulkan raster_backend");
  vulkan->reserve_frames(frames);
}

}  // namespace gr::vulkan
