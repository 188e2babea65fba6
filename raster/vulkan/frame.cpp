// The Frame's calls: each records its uploads, passes and downloads into one
// command buffer with timestamps between them, submits it and waits, then
// copies the downloads into the caller's arrays; on a thread that defers
// (Device::Impl::run), the waiting and copying happen at the deferral's end.
#include "raster/vulkan/frame.h"

#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/antialias.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/vulkan/internal/buffer.h"
#include "raster/vulkan/internal/kernels.h"

namespace gr::vulkan {
namespace {

// Frame::antialias_serial's and interpolate_serial's source: unique in the process, never 0.
std::atomic<std::uint64_t> g_call_serial{0};

// Bytes of one antialias pair slot (struct Pair, antialias_common.glsl): t, a, b.
constexpr std::size_t kPairBytes = 16;

// Workgroups of raster_large; their invocations take the listed chunks in turn.
constexpr std::uint32_t kLargeWorkgroups = 1024;
// Timestamps of the call that stamps the most (rasterize).
constexpr std::uint32_t kMaxTimestamps = 9;

struct RasterPush {
  std::int32_t width, height, num_vertices, num_tris, cull, pass, y_up, flags;
};
struct InterpolatePush {
  std::int32_t width, height, num_vertices, num_tris, channels, pass, num_diff, count;
};
struct GBufferPush {
  std::int32_t width, height, num_vertices, num_tris, pass, y_up, flags, count;
};
// gbuffer_backward.comp's flags: which incoming G-buffer gradients are present.
constexpr std::int32_t kDeviceRast = 1, kDeviceDb = 2, kHostRast = 4, kHostDb = 8;
struct FinishPush {
  std::int32_t count, split, pixels, pad[5];
};
// id_offset: the row of the list the shaders read (binding 1) where the
// G-buffer's triangles start (antialias's `whole`), added to its ids.
struct AntialiasPush {
  std::int32_t width, height, num_vertices, id_offset, channels, pass, y_up, visibility;
};
static_assert(sizeof(RasterPush) == kPushBytes && sizeof(InterpolatePush) == kPushBytes &&
                  sizeof(GBufferPush) == kPushBytes &&
                  sizeof(FinishPush) == kPushBytes && sizeof(AntialiasPush) == kPushBytes,
              "push constant blocks");

// The frame's buffers by role (device-local), and two host-visible staging buffers.
enum Role {
  kClip, kTris, kVerts, kKeys, kIds, kLarge, kTriId, kRast, kDb,  // mesh, coverage and G-buffer
  kUv, kDepth,  // rasterize_coverage's screen-space uv and depth
  kAttr, kDiff, kInterpolated, kDa, kGradIn,  // interpolate (kGradIn: grad_out, then grad_da)
  kGradGBuffer,  // the G-buffer's gradient on the device: H*W*4 rast, then H*W*4 db
  kHostGradGBuffer,  // rasterize_backward's from the host, in the same layout
  kSums, kLargest, kFinished,  // an adjoint's fixed-point sums, their scales, its result
  kNeighbour, kAaImage, kAaOut, kAaPairs, kAaGradOut, kAaGradImage,  // antialias
  kAaTris,  // antialias's whole list, of which a range mode G-buffer drew a part
  kFloor,  // depth peeling: the previous layer's key per pixel (FloorKey)
  kRoles
};

}  // namespace

struct Frame::State {
  State(Device::Impl& dev, Kernels& k)
      : dev(dev), k(k), raster_set(dev, k.pipelines), forward_set(dev, k.pipelines), backward_set(dev, k.pipelines),
        raster_backward_set(dev, k.pipelines), finish_set(dev, k.pipelines), aa_forward_set(dev, k.pipelines),
        aa_backward_set(dev, k.pipelines), timestamps(dev, kMaxTimestamps) {}

  Device::Impl& dev;
  Kernels& k;
  Buffer buffers[kRoles];
  Buffer upload, download;
  DescriptorSet raster_set, forward_set, backward_set, raster_backward_set, finish_set, aa_forward_set,
      aa_backward_set;
  Timestamps timestamps;
  // What the last rasterize and interpolate were given.
  int width = 0, height = 0;
  std::int64_t num_vertices = 0, num_tris = 0;
  bool y_up = false, rasterized = false, derivatives = false;
  std::int64_t channels = -1, num_diff = 0;
  std::uint64_t ip_serial = 0;  // of the last interpolate (0: none)
  // The device's G-buffer gradient (kGradGBuffer) holds values (rast, db)
  // since the last rasterize or rasterize_backward; else it is stale.
  bool grad_rast = false, grad_db = false;
  int aa_channels = -1;  // of the last antialias (-1: none since the last rasterize)
  std::uint64_t aa_serial = 0;  // of the last antialias (0: none)
  bool aa_visibility = false;  // the last antialias was visibility_antialias's
  // The last antialias read the whole list in kAaTris, the G-buffer's ids
  // offset by aa_first (a range mode G-buffer); else the frame's own, kTris.
  bool aa_whole = false;
  std::int32_t aa_first = 0;
  // The host copy of what kAaTris holds once aa_tris_on_device.
  std::vector<std::int32_t> aa_tris;
  bool aa_tris_on_device = false;
  // What the device's edge topology (kNeighbour) holds: the adjacency of
  // `tris` (the frame's own) once topology_ready, or the caller's EdgeTopology
  // of serial neighbour_serial (0: none); never both. An EdgeTopology is
  // immutable, so its serial names its content whatever triangles the frame
  // has since (antialias checks the triangle count).
  std::vector<std::int32_t> tris;
  bool topology_ready = false;
  std::uint64_t neighbour_serial = 0;
  Uploads topology_uploads;
  // kTris holds `tris` (a mesh's triangles stay the same call after call:
  // they go up once, issue 33).
  bool tris_on_device = false;
  Uploads triangle_uploads;

  // The frame's last call, if the device deferred it (Device::Impl::run):
  // its buffers are in use until it completes.
  std::uint64_t ticket = 0;

  // Completes the frame's deferred call, if any, before a call reuses its
  // buffers (the caller holds dev.mutex).
  void settle() {
    if (dev.pending(ticket)) dev.complete();
  }
  // The call's times once it has run; none while it is deferred.
  GpuTimes times() const { return dev.pending(ticket) ? GpuTimes{} : timestamps.read(); }

  Buffer& operator[](Role r) { return buffers[r]; }
  std::int64_t pixels() const { return static_cast<std::int64_t>(width) * height; }
  void reserve(Role r, std::size_t bytes) { buffers[r].reserve(dev, bytes, false); }
  VkDescriptorSet bind(DescriptorSet& set, std::initializer_list<std::pair<std::uint32_t, Role>> bindings) {
    VkBuffer handles[kBindings] = {};
    for (const auto& [binding, role] : bindings) handles[binding] = buffers[role].handle();
    return set.bind(handles);
  }
  // A new G-buffer of p's mesh and size (rasterized or loaded): what the ops
  // before it left on the device no longer applies.
  void begin_gbuffer(const raster::RasterParams<float>& p, bool y_up_option, bool with_derivatives) {
    rasterized = false;
    width = p.settings.width;
    height = p.settings.height;
    num_vertices = p.num_vertices;
    num_tris = p.num_tris;
    y_up = y_up_option || p.settings.y_up;
    derivatives = with_derivatives;
    channels = -1;
    ip_serial = 0;
    aa_channels = -1;
    aa_serial = 0;
    aa_whole = false;
    aa_first = 0;
    grad_rast = grad_db = false;
    note_triangles(p.tris, p.num_tris);
  }
  // Keeps the host copy of the triangles; the topology is stale when they changed.
  void note_triangles(const std::int32_t* t, std::int64_t num_tris) {
    const std::size_t n = static_cast<std::size_t>(3 * num_tris);
    if (tris.size() == n && (n == 0 || std::memcmp(tris.data(), t, n * sizeof(std::int32_t)) == 0)) return;
    tris.assign(t, t + n);
    topology_ready = false;
    tris_on_device = false;
  }
  // The bytes of the triangle list this call uploads into kTris (0: it holds
  // them already); kTris is sized, and marked stale until finish_triangles.
  std::size_t triangles_to_upload() {
    const std::size_t bytes = tris.size() * sizeof(std::int32_t);
    if (tris_on_device) return 0;
    reserve(kTris, bytes);
    return bytes;
  }
  // After the upload of `bytes` (from triangles_to_upload) went through.
  void finish_triangles(std::size_t bytes) {
    if (tris_on_device) return;
    tris_on_device = true;
    ++triangle_uploads.uploads;
    triangle_uploads.bytes += static_cast<std::int64_t>(bytes);
  }
  void use(VkCommandBuffer cb, VkDescriptorSet set) {
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipelines.layout(), 0, 1, &set, 0, nullptr);
  }
  // The adjoints' passes (fixed_point.glsl), after stamp 1: zero `count`
  // fixed-point sums and the two largest magnitudes; `pipeline` over the
  // pixels with pass 0 (magnitudes), then 1 (sums); `finish` (with
  // finish_set, default `set`) over `finish_items`. Stamps 2, 3 and 4 after them.
  template <class Push, class FinishPush>
  void fixed_point_passes(VkCommandBuffer cb, VkDescriptorSet set, Role sums, std::size_t count, Role largest,
                          VkPipeline pipeline, Push push, VkPipeline finish, const FinishPush& finish_push,
                          std::int64_t finish_items, VkDescriptorSet finish_set = VK_NULL_HANDLE) {
    if (count > 0) vkCmdFillBuffer(cb, buffers[sums].handle(), 0, count * sizeof(std::int64_t), 0u);
    vkCmdFillBuffer(cb, buffers[largest].handle(), 0, 2 * sizeof(std::uint64_t), 0u);
    barrier(cb);
    use(cb, set);
    for (std::int32_t pass = 0; pass < 2; ++pass) {
      push.pass = pass;
      dispatch(cb, k, pipeline, &push, pixels(), 256);
      barrier(cb);
      timestamps.stamp(cb, 2 + pass);
    }
    if (finish_set != VK_NULL_HANDLE) use(cb, finish_set);
    dispatch(cb, k, finish, &finish_push, finish_items, 256);
    barrier(cb);
    timestamps.stamp(cb, 4);
  }
};

namespace {

// EdgeTopology::neighbour of the frame's triangles as int32 (3n + k' or < 0).
std::vector<std::int32_t> neighbours_of(const std::vector<std::int32_t>& tris) {
  const std::int64_t num_tris = static_cast<std::int64_t>(tris.size() / 3);
  if (3 * num_tris > std::numeric_limits<std::int32_t>::max())
    throw ValueError("vulkan antialias: too many triangles for 32-bit edge indices (" + std::to_string(num_tris) + ")");
  const raster::EdgeTopology topo = raster::build_edge_topology(tris.data(), num_tris);
  return std::vector<std::int32_t>(topo.neighbour().begin(), topo.neighbour().end());
}

// raster_common.glsl's depth_key on the host (an order-preserving map of a
// double's bits, -0 as +0) and its inverse for the winning keys; the key of
// no fragment (all ones, the cleared value) gives +inf, as the CPU's key_depth.
std::uint64_t depth_key(double z) {
  std::uint64_t bits;
  std::memcpy(&bits, &z, sizeof bits);
  constexpr std::uint64_t kSign = 0x8000000000000000ull;
  if (bits == kSign) bits = 0;
  return (bits & kSign) ? ~bits : bits | kSign;
}

double depth_of_key(std::uint64_t key) {
  if (key == ~std::uint64_t(0)) return std::numeric_limits<double>::infinity();
  constexpr std::uint64_t kSign = 0x8000000000000000ull;
  const std::uint64_t bits = (key & kSign) ? key & ~kSign : ~key;
  double z;
  std::memcpy(&z, &bits, sizeof z);
  return z;
}

// A pixel's peeling floor as raster_pixels.glsl reads it.
struct FloorKey {
  std::uint64_t key;
  std::int32_t id, pad;
};
static_assert(sizeof(FloorKey) == 16, "FloorKey is 16 bytes (std430)");

// dst[0, n) += src[0, n) when dst is given (the adjoints accumulate, as on the CPU).
void add_to(float* dst, const float* src, std::int64_t n) {
  if (dst)
    for (std::int64_t i = 0; i < n; ++i) dst[i] += src[i];
}

// What the shaders index with 32-bit ints: 4 N clip values, 3 M indices,
// H W C image values.
constexpr std::int64_t kMaxIndex = std::numeric_limits<std::int32_t>::max();

// The checks the CPU ops make (ops/check.h), here at the Frame's boundary:
// the shaders trust them.
void check_raster_params(const raster::RasterParams<float>& p) {
  const char* op = "vulkan rasterize";
  raster::detail::check_image_size(p.settings.width, p.settings.height, op);
  if (p.num_vertices < 0 || p.num_tris < 0 || 4 * p.num_vertices > kMaxIndex || 3 * p.num_tris > kMaxIndex)
    throw ValueError(std::string(op) + ": " + std::to_string(p.num_vertices) + " vertices and " +
                     std::to_string(p.num_tris) + " triangles: the GPU path takes at most " +
                     std::to_string(kMaxIndex / 4) + " and " + std::to_string(kMaxIndex / 3));
  if ((p.num_vertices > 0 && !p.clip) || (p.num_tris > 0 && !p.tris))
    throw ValueError(std::string(op) + ": clip or triangles missing");
  raster::detail::check_triangles(p.tris, p.num_tris, p.num_vertices, op);
  raster::detail::check_finite(p.clip, 4 * p.num_vertices, "clip", op);
}

// An image of `channels` per pixel must be indexable too.
void check_channels(std::int64_t channels, std::int64_t pixels, const char* op) {
  if (channels < 0 || (channels > 0 && pixels * channels > kMaxIndex))
    throw ValueError(std::string(op) + ": " + std::to_string(channels) + " channels of " + std::to_string(pixels) +
                     " pixels: at most " + std::to_string(kMaxIndex) + " values on the GPU path");
}

// A range mode G-buffer's whole list (Frame::antialias): its rows from
// whole.first on must be the frame's triangles, and the topology (needed) of it.
void check_whole_triangles(const WholeTriangles& whole, const std::vector<std::int32_t>& frame_tris,
                           const raster::EdgeTopology* topology) {
  const char* op = "vulkan antialias";
  const std::int64_t count = static_cast<std::int64_t>(frame_tris.size() / 3);
  if (whole.num_tris < 0 || whole.first < 0 || whole.first > whole.num_tris - count ||
      3 * whole.num_tris > kMaxIndex || (whole.num_tris > 0 && !whole.tris))
    throw ValueError(std::string(op) + ": the frame's " + std::to_string(count) + " triangles are no range of a "
                     "whole list of " + std::to_string(whole.num_tris) + " from row " + std::to_string(whole.first));
  if (count > 0 && std::memcmp(whole.tris + 3 * whole.first, frame_tris.data(), frame_tris.size() * sizeof(std::int32_t)) != 0)
    throw ValueError(std::string(op) + ": rows " + std::to_string(whole.first) + ".." +
                     std::to_string(whole.first + count - 1) + " of the whole list are not the frame's triangles");
  if (!topology) throw ValueError(std::string(op) + ": a range's G-buffer needs the whole list's edge topology");
}

}  // namespace

Frame::Frame(std::shared_ptr<Device> device) : device_(std::move(device)) {
  if (!device_) throw ValueError("vulkan Frame: no device");
  Device::Impl& dev = device_->impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  state_ = std::make_unique<State>(dev, kernels_of(dev));
}

Frame::~Frame() {
  if (!state_) return;
  std::lock_guard<std::mutex> lock(state_->dev.mutex);
  try {
    state_->settle();
  } catch (...) {
  }
  state_.reset();
}

GpuTimes Frame::rasterize(const raster::RasterParams<float>& p, const GpuRasterOptions& options, std::int32_t* tri_id,
                          float* rast, float* db, double* key_depth) {
  if (db && !options.derivatives)
    throw ValueError("vulkan rasterize: db asked for without options.derivatives");
  void* const outs[3] = {tri_id, rast, db};
  return rasterize_into(p, options, false, outs, key_depth);
}

GpuTimes Frame::rasterize_coverage(const raster::RasterParams<float>& p, const GpuRasterOptions& options,
                                   std::int32_t* tri_id, float* uv, float* depth, double* key_depth) {
  void* const outs[3] = {tri_id, uv, depth};
  return rasterize_into(p, options, true, outs, key_depth);
}

// coverage: the resolve pass also writes the coverage kernel's uv and depth
// (outs: tri_id, uv, depth) and no G-buffer is made; else the G-buffer pass
// follows (outs: tri_id, rast, db).
GpuTimes Frame::rasterize_into(const raster::RasterParams<float>& p, const GpuRasterOptions& options, bool coverage,
                               void* const (&outs)[3], double* key_depth) {
  if (!p.floor_id != !p.floor_z)
    throw ValueError("vulkan rasterize: depth peeling needs both floor_id and floor_z (or neither)");
  const bool peel = p.floor_id != nullptr;
  if (options.small_box < 1)
    throw ValueError("vulkan rasterize: small_box must be at least 1, got " + std::to_string(options.small_box));
  check_raster_params(p);
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  s.begin_gbuffer(p, options.y_up, !coverage && options.derivatives);
  const std::size_t px = static_cast<std::size_t>(s.pixels());
  const std::size_t clip_bytes = static_cast<std::size_t>(p.num_vertices) * 4 * sizeof(float);
  const std::size_t tri_bytes = s.triangles_to_upload();
  // Per pixel: tri_id, then uv and depth (coverage) or rast and db.
  const std::size_t values[3] = {1, coverage ? std::size_t(2) : std::size_t(4), coverage ? std::size_t(1) : std::size_t(4)};
  const Role roles[3] = {kTriId, coverage ? kUv : kRast, coverage ? kDepth : kDb};
  const bool made[3] = {true, true, coverage || s.derivatives};
  std::size_t out_bytes[3];
  for (int i = 0; i < 3; ++i) out_bytes[i] = outs[i] && made[i] ? px * values[i] * 4 : 0;
  const std::size_t floor_bytes = peel ? px * sizeof(FloorKey) : 0;
  const std::size_t key_bytes = key_depth ? px * sizeof(std::uint64_t) : 0;
  // The floors and keys sit 16-byte aligned in the staging buffers, after the rest.
  const auto aligned = [](std::size_t n) { return (n + 15) / 16 * 16; };
  const std::size_t floor_at = aligned(clip_bytes + tri_bytes);
  const std::size_t key_at = aligned(out_bytes[0] + out_bytes[1] + out_bytes[2]);
  s.reserve(kClip, clip_bytes);
  s.reserve(kVerts, static_cast<std::size_t>(p.num_vertices) * 32);
  s.reserve(kKeys, px * sizeof(std::uint64_t));
  s.reserve(kIds, px * sizeof(std::int32_t));
  s.reserve(kLarge, (static_cast<std::size_t>(p.num_tris) + 1) * 2 * sizeof(std::uint32_t));
  for (int i = 0; i < 3; ++i)
    if (made[i]) s.reserve(roles[i], px * values[i] * 4);
  s.reserve(kFloor, floor_bytes);
  s.upload.reserve(s.dev, floor_at + floor_bytes, true);
  s.download.reserve(s.dev, key_at + key_bytes, true);
  char* up = static_cast<char*>(s.upload.mapped());
  if (clip_bytes) std::memcpy(up, p.clip, clip_bytes);
  if (tri_bytes) std::memcpy(up + clip_bytes, p.tris, tri_bytes);
  if (peel) {
    // A NaN depth lets nothing through on the CPU (no comparison holds): as a background floor.
    FloorKey* floors = reinterpret_cast<FloorKey*>(up + floor_at);
    for (std::size_t i = 0; i < px; ++i)
      floors[i] = {depth_key(p.floor_z[i]), std::isnan(p.floor_z[i]) ? 0 : p.floor_id[i], 0};
  }

  // Raster shaders' bindings: 0 clip, 1 tris, 2 verts, 3 keys, 4 ids, 5 large list, 6 tri_id, 7-8 uv and
  // depth (resolve, coverage) or rast and db (gbuffer; without db, binding 8 is unused: rast stands in),
  // 9 the peeling floor (unused without: keys stand in).
  const VkDescriptorSet set = s.bind(s.raster_set, {{0, kClip}, {1, kTris}, {2, kVerts}, {3, kKeys}, {4, kIds},
                                                    {5, kLarge}, {6, kTriId}, {7, roles[1]},
                                                    {8, made[2] ? roles[2] : roles[1]}, {9, peel ? kFloor : kKeys}});
  const VkPipeline small = s.k.raster_small(options.small_box);
  RasterPush push{s.width, s.height, static_cast<std::int32_t>(p.num_vertices), static_cast<std::int32_t>(p.num_tris),
                  p.settings.cull == raster::Cull::Back ? 1 : p.settings.cull == raster::Cull::Front ? -1 : 0,
                  0, s.y_up ? 1 : 0, (coverage ? 1 : 0) | (peel ? 2 : 0)};
  const GBufferPush gpush{s.width, s.height, static_cast<std::int32_t>(p.num_vertices),
                          static_cast<std::int32_t>(p.num_tris), 0, s.y_up ? 1 : 0, s.derivatives ? 1 : 0, 0};
  const std::uint32_t last = coverage ? 7 : 8;
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, last + 1);
    copy(cb, s.upload.handle(), 0, s[kClip].handle(), 0, clip_bytes);
    copy(cb, s.upload.handle(), clip_bytes, s[kTris].handle(), 0, tri_bytes);
    copy(cb, s.upload.handle(), floor_at, s[kFloor].handle(), 0, floor_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    // Keys "beyond everything", ids "none", an empty large list.
    vkCmdFillBuffer(cb, s[kKeys].handle(), 0, px * sizeof(std::uint64_t), 0xffffffffu);
    vkCmdFillBuffer(cb, s[kIds].handle(), 0, px * sizeof(std::int32_t), 0x7fffffffu);
    vkCmdFillBuffer(cb, s[kLarge].handle(), 0, sizeof(std::uint64_t), 0u);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
    s.use(cb, set);
    dispatch(cb, s.k, s.k.project, &push, p.num_vertices, 256);
    barrier(cb);
    s.timestamps.stamp(cb, 3);
    for (std::int32_t pass = 0; pass < 2; ++pass) {
      push.pass = pass;
      dispatch(cb, s.k, small, &push, p.num_tris, 64);
      barrier(cb);
      if (p.num_tris > 0) dispatch(cb, s.k, s.k.raster_large, &push, std::int64_t(kLargeWorkgroups) * 256, 256);
      barrier(cb);
      s.timestamps.stamp(cb, 4 + pass);
    }
    dispatch(cb, s.k, s.k.resolve, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 6);
    if (!coverage) {
      dispatch(cb, s.k, s.k.gbuffer, &gpush, s.pixels(), 256);
      barrier(cb);
      s.timestamps.stamp(cb, 7);
    }
    std::size_t offset = 0;
    for (int i = 0; i < 3; ++i) {
      copy(cb, s[roles[i]].handle(), 0, s.download.handle(), offset, out_bytes[i]);
      offset += out_bytes[i];
    }
    copy(cb, s[kKeys].handle(), 0, s.download.handle(), key_at, key_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, last);
  };
  const std::array<void*, 3> to{outs[0], outs[1], outs[2]};
  const std::array<std::size_t, 3> sizes{out_bytes[0], out_bytes[1], out_bytes[2]};
  s.ticket = s.dev.run(record, [&s, to, sizes, key_depth, key_at, px] {
    const char* from = static_cast<const char*>(s.download.mapped());
    for (int i = 0; i < 3; ++i) {
      if (sizes[i]) std::memcpy(to[i], from, sizes[i]);
      from += sizes[i];
    }
    if (key_depth) {
      const std::uint64_t* keys = reinterpret_cast<const std::uint64_t*>(static_cast<const char*>(s.download.mapped()) + key_at);
      for (std::size_t i = 0; i < px; ++i) key_depth[i] = depth_of_key(keys[i]);
    }
  });
  s.finish_triangles(tri_bytes);
  s.rasterized = !coverage;
  return s.times();
}

GpuTimes Frame::load_gbuffer(const raster::RasterParams<float>& p, const GpuRasterOptions& options,
                             const std::int32_t* tri_id, const float* uv, int uv_stride, const float* depth,
                             const float* db) {
  const char* op = "vulkan load_gbuffer";
  if (p.floor_id || p.floor_z) throw ValueError(std::string(op) + ": depth peeling fields must be null");
  check_raster_params(p);
  if (!tri_id) throw ValueError(std::string(op) + ": tri_id is missing");
  if (uv && uv_stride < 2) throw ValueError(std::string(op) + ": uv_stride must be at least 2");
  const std::int64_t px = std::int64_t(p.settings.width) * p.settings.height;
  for (std::int64_t q = 0; q < px; ++q)
    if (tri_id[q] < 0 || tri_id[q] > p.num_tris)
      throw IndexError(std::string(op) + ": tri_id of pixel " + std::to_string(q) + " is " +
                       std::to_string(tri_id[q]) + ", outside [0, " + std::to_string(p.num_tris) + "]");
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  s.begin_gbuffer(p, options.y_up, options.derivatives);
  s.topology_ready = false;  // the caller's triangles may come with another topology
  const std::size_t clip_bytes = static_cast<std::size_t>(p.num_vertices) * 4 * sizeof(float);
  const std::size_t tri_bytes = s.triangles_to_upload();
  const std::size_t id_bytes = static_cast<std::size_t>(px) * sizeof(std::int32_t);
  const std::size_t plane = static_cast<std::size_t>(px) * 4 * sizeof(float);
  const std::size_t db_bytes = db ? plane : 0;
  s.reserve(kClip, clip_bytes);
  s.reserve(kVerts, static_cast<std::size_t>(p.num_vertices) * 32);
  s.reserve(kKeys, 16);
  s.reserve(kIds, 16);
  s.reserve(kLarge, 16);
  s.reserve(kTriId, id_bytes);
  s.reserve(kRast, plane);
  s.reserve(kDb, s.derivatives ? plane : 16);
  s.upload.reserve(s.dev, clip_bytes + tri_bytes + id_bytes + plane + db_bytes, true);
  char* up = static_cast<char*>(s.upload.mapped());
  if (clip_bytes) std::memcpy(up, p.clip, clip_bytes);
  if (tri_bytes) std::memcpy(up + clip_bytes, p.tris, tri_bytes);
  std::memcpy(up + clip_bytes + tri_bytes, tri_id, id_bytes);
  // rast as the G-buffer pass writes it: u, v, z/w, id.
  float* rast = reinterpret_cast<float*>(up + clip_bytes + tri_bytes + id_bytes);
  for (std::int64_t q = 0; q < px; ++q) {
    rast[4 * q] = uv ? uv[uv_stride * q] : 0.0f;
    rast[4 * q + 1] = uv ? uv[uv_stride * q + 1] : 0.0f;
    rast[4 * q + 2] = depth ? depth[q] : 0.0f;
    rast[4 * q + 3] = static_cast<float>(tri_id[q]);
  }
  if (db_bytes) std::memcpy(up + clip_bytes + tri_bytes + id_bytes + plane, db, db_bytes);
  const VkDescriptorSet set = s.bind(s.raster_set, {{0, kClip}, {1, kTris}, {2, kVerts}, {3, kKeys}, {4, kIds},
                                                    {5, kLarge}, {6, kTriId}, {7, kRast}, {8, kDb}});
  const RasterPush push{s.width, s.height, static_cast<std::int32_t>(p.num_vertices),
                        static_cast<std::int32_t>(p.num_tris), 0, 0, s.y_up ? 1 : 0, 0};
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 3);
    std::size_t offset = 0;
    const std::pair<Role, std::size_t> parts[5] = {
        {kClip, clip_bytes}, {kTris, tri_bytes}, {kTriId, id_bytes}, {kRast, plane}, {kDb, db_bytes}};
    for (const auto& part : parts) {
      copy(cb, s.upload.handle(), offset, s[part.first].handle(), 0, part.second);
      offset += part.second;
    }
    if (s.derivatives && !db) vkCmdFillBuffer(cb, s[kDb].handle(), 0, plane, 0u);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.use(cb, set);
    dispatch(cb, s.k, s.k.project, &push, p.num_vertices, 256);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
  };
  s.ticket = s.dev.run(record, [] {});
  s.finish_triangles(tri_bytes);
  s.rasterized = true;
  return s.times();
}

GpuTimes Frame::interpolate(const float* attr, std::int64_t channels, float* out, const std::int32_t* diff,
                            std::int64_t num_diff, float* out_da) {
  State& s = *state_;
  const char* op = "vulkan interpolate";
  if (!s.rasterized) throw ValueError(std::string(op) + ": the frame has no G-buffer (call rasterize first)");
  check_channels(channels, s.pixels(), op);
  if (!attr && s.num_vertices * channels > 0) throw ValueError(std::string(op) + ": attr is missing");
  if (num_diff < 0 || (num_diff > 0 && !diff))
    throw ValueError(std::string(op) + ": diff is missing for " + std::to_string(num_diff) + " channels");
  if (num_diff > 0 && !s.derivatives)
    throw ValueError(std::string(op) + ": attribute derivatives need a G-buffer with rast_db "
                     "(rasterize with GpuRasterOptions::derivatives)");
  check_channels(2 * num_diff, s.pixels(), op);
  for (std::int64_t j = 0; j < num_diff; ++j)
    if (diff[j] < 0 || diff[j] >= channels)
      throw IndexError(std::string(op) + ": diff[" + std::to_string(j) + "] = " + std::to_string(diff[j]) +
                       " is not a channel in [0, " + std::to_string(channels) + ")");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  s.channels = channels;
  s.num_diff = num_diff;
  s.ip_serial = 0;
  const std::size_t attr_bytes = static_cast<std::size_t>(s.num_vertices * channels) * sizeof(float);
  const std::size_t diff_bytes = static_cast<std::size_t>(num_diff) * sizeof(std::int32_t);
  const std::size_t out_bytes = static_cast<std::size_t>(s.pixels() * channels) * sizeof(float);
  const std::size_t da_bytes = static_cast<std::size_t>(s.pixels() * 2 * num_diff) * sizeof(float);
  const std::size_t down[2] = {out ? out_bytes : 0, out_da ? da_bytes : 0};
  s.reserve(kAttr, attr_bytes);
  s.reserve(kDiff, diff_bytes);
  s.reserve(kInterpolated, out_bytes);
  s.reserve(kDa, da_bytes);
  s.upload.reserve(s.dev, attr_bytes + diff_bytes, true);
  s.download.reserve(s.dev, down[0] + down[1], true);
  if (attr_bytes) std::memcpy(s.upload.mapped(), attr, attr_bytes);
  if (diff_bytes) std::memcpy(static_cast<char*>(s.upload.mapped()) + attr_bytes, diff, diff_bytes);
  // Interpolate shaders' bindings: 0 attr, 1 tris, 2 tri_id, 3 rast, 4 db, 5 diff, 6 out, 7 out_da (unused
  // bindings: stand-ins of the right kind).
  const Role db = s.derivatives ? kDb : kRast, diffs = num_diff > 0 ? kDiff : kTris, da = num_diff > 0 ? kDa : kRast;
  const VkDescriptorSet set = s.bind(s.forward_set, {{0, kAttr}, {1, kTris}, {2, kTriId}, {3, kRast}, {4, db},
                                                     {5, diffs}, {6, kInterpolated}, {7, da}});
  const InterpolatePush push{s.width, s.height, static_cast<std::int32_t>(s.num_vertices),
                             static_cast<std::int32_t>(s.num_tris), static_cast<std::int32_t>(channels),
                             0, static_cast<std::int32_t>(num_diff), 0};
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 4);
    copy(cb, s.upload.handle(), 0, s[kAttr].handle(), 0, attr_bytes);
    copy(cb, s.upload.handle(), attr_bytes, s[kDiff].handle(), 0, diff_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.use(cb, set);
    if (channels > 0) dispatch(cb, s.k, s.k.interpolate_forward, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
    copy(cb, s[kInterpolated].handle(), 0, s.download.handle(), 0, down[0]);
    copy(cb, s[kDa].handle(), 0, s.download.handle(), down[0], down[1]);
    barrier(cb);
    s.timestamps.stamp(cb, 3);
  };
  const std::size_t out_size = down[0], da_size = down[1];
  s.ticket = s.dev.run(record, [&s, out, out_da, out_size, da_size] {
    const char* got = static_cast<const char*>(s.download.mapped());
    if (out_size) std::memcpy(out, got, out_size);
    if (da_size) std::memcpy(out_da, got + out_size, da_size);
  });
  s.ip_serial = ++g_call_serial;
  return s.times();
}

GpuTimes Frame::interpolate_backward(const float* grad_out, const float* grad_da, float* grad_attr,
                                     float* grad_rast, float* grad_db) {
  State& s = *state_;
  if (s.channels < 0) throw ValueError("vulkan interpolate_backward: the frame has no interpolate to differentiate");
  if (!grad_out && s.pixels() * s.channels > 0)  // no channels: an empty grad_out (its data may be null)
    throw ValueError("vulkan interpolate_backward: grad_out is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  // Without grad_da the derivatives get no gradient (nor does rast_db), as on the CPU.
  const std::int64_t N = s.num_vertices, C = s.channels, K = grad_da ? s.num_diff : 0, px = s.pixels();
  const std::size_t out_bytes = static_cast<std::size_t>(px * C) * sizeof(float);
  const std::size_t da_bytes = static_cast<std::size_t>(px * 2 * K) * sizeof(float);
  const std::size_t sums = static_cast<std::size_t>(N * C);
  const std::size_t plane = static_cast<std::size_t>(px) * 4 * sizeof(float);
  // The G-buffer's gradient goes to the host (grad_rast or grad_db given) or
  // is added to the device's own (kGradGBuffer, zeroed on first use).
  const bool to_host = grad_rast || grad_db;
  const Role gbuffer_grad = to_host ? kHostGradGBuffer : kGradGBuffer;
  const std::size_t down[3] = {grad_attr ? sums * sizeof(float) : 0, grad_rast ? plane : 0,
                               grad_db && K > 0 ? plane : 0};
  s.reserve(kGradIn, out_bytes + da_bytes);
  s.reserve(gbuffer_grad, 2 * plane);
  s.reserve(kSums, sums * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));
  s.reserve(kFinished, sums * sizeof(float));
  s.upload.reserve(s.dev, out_bytes + da_bytes, true);
  s.download.reserve(s.dev, down[0] + down[1] + down[2], true);
  if (out_bytes) std::memcpy(s.upload.mapped(), grad_out, out_bytes);
  if (da_bytes) std::memcpy(static_cast<char*>(s.upload.mapped()) + out_bytes, grad_da, da_bytes);
  // Bindings: 0-5 as the forward, 6 grad_out and grad_da, 7 sums, 8 largest magnitudes, 9 the G-buffer
  // gradient; the finish: 7 sums, 8 largest, 9 finished sums.
  const Role db = s.derivatives ? kDb : kRast, diffs = s.num_diff > 0 ? kDiff : kTris;
  const VkDescriptorSet set = s.bind(s.backward_set, {{0, kAttr}, {1, kTris}, {2, kTriId}, {3, kRast}, {4, db},
                                                      {5, diffs}, {6, kGradIn}, {7, kSums}, {8, kLargest},
                                                      {9, gbuffer_grad}});
  const VkDescriptorSet finish_set = s.bind(s.finish_set, {{7, kSums}, {8, kLargest}, {9, kFinished}});
  // Per element at most one contribution per pixel and vertex slot (3, for
  // triangles repeating a vertex), per channel and its derivatives.
  const std::int64_t count = 3 * px * (1 + K);
  if (count > kMaxIndex)
    throw ValueError("vulkan interpolate_backward: " + std::to_string(K) + " derivative channels of " +
                     std::to_string(px) + " pixels: the fixed-point sums take at most " + std::to_string(kMaxIndex) +
                     " contributions per element (3 x pixels x (1 + derivative channels))");
  const InterpolatePush push{s.width, s.height, static_cast<std::int32_t>(N), static_cast<std::int32_t>(s.num_tris),
                             static_cast<std::int32_t>(C), 0, static_cast<std::int32_t>(K),
                             static_cast<std::int32_t>(count)};
  const FinishPush finish{static_cast<std::int32_t>(sums), static_cast<std::int32_t>(sums), push.count, {}};
  const bool zero_rast = to_host || !s.grad_rast, zero_db = K > 0 && (to_host || !s.grad_db);
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kGradIn].handle(), 0, out_bytes + da_bytes);
    if (zero_rast) vkCmdFillBuffer(cb, s[gbuffer_grad].handle(), 0, plane, 0u);
    if (zero_db) vkCmdFillBuffer(cb, s[gbuffer_grad].handle(), plane, plane, 0u);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, sums, kLargest, s.k.interpolate_backward, push, s.k.fixed_point_finish,
                         finish, static_cast<std::int64_t>(sums), finish_set);
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), 0, down[0]);
    copy(cb, s[gbuffer_grad].handle(), 0, s.download.handle(), down[0], down[1]);
    copy(cb, s[gbuffer_grad].handle(), plane, s.download.handle(), down[0] + down[1], down[2]);
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  };
  // Values per host gradient: attr, rast, db.
  const std::array<std::int64_t, 3> n{N * C, static_cast<std::int64_t>(down[1] / sizeof(float)),
                                      static_cast<std::int64_t>(down[2] / sizeof(float))};
  s.ticket = s.dev.run(record, [&s, n, grad_attr, grad_rast, grad_db] {
    const float* got = static_cast<const float*>(s.download.mapped());
    add_to(grad_attr, got, n[0]);
    add_to(grad_rast, got + (grad_attr ? n[0] : 0), n[1]);
    add_to(grad_db, got + (grad_attr ? n[0] : 0) + n[1], n[2]);
  });
  if (!to_host) {
    s.grad_rast = true;
    s.grad_db = s.grad_db || K > 0;
  }
  return s.times();
}

GpuTimes Frame::antialias(const float* image, int channels, float* out, const raster::EdgeTopology* topology,
                          bool visibility, const WholeTriangles* whole) {
  State& s = *state_;
  if (!s.rasterized) throw ValueError("vulkan antialias: the frame has no G-buffer (call rasterize first)");
  if (channels < 1) throw ValueError("vulkan antialias: channels must be at least 1, got " + std::to_string(channels));
  check_channels(channels, s.pixels(), "vulkan antialias");
  if (!image && s.channels != channels)
    throw ValueError("vulkan antialias: no image given, and the last interpolate's output has " +
                     (s.channels < 0 ? std::string("not been made") : std::to_string(s.channels) + " channels") +
                     ", not " + std::to_string(channels));
  // A range mode G-buffer's pairs walk the whole list (ids offset by its first row).
  if (whole && whole->first == 0 && whole->num_tris == s.num_tris) whole = nullptr;  // the frame's own list
  if (whole) check_whole_triangles(*whole, s.tris, topology);
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  s.aa_channels = -1;
  s.aa_serial = 0;
  const std::size_t px = static_cast<std::size_t>(s.pixels());
  const std::size_t image_bytes = px * static_cast<std::size_t>(channels) * sizeof(float);
  // No image: the last interpolate's output, copied on the device.
  const std::size_t upload_image = image ? image_bytes : 0;
  const std::int64_t list_tris = whole ? whole->num_tris : s.num_tris;
  if (topology && topology->num_tris() != list_tris)
    throw ValueError("vulkan antialias: the topology was built for " + std::to_string(topology->num_tris()) +
                     " triangles, the " + (whole ? "whole list" : "frame") + " has " + std::to_string(list_tris));
  // The whole list goes up unless kAaTris holds it (checked when it does not).
  std::size_t whole_bytes = 0;
  if (whole) {
    const std::size_t n = static_cast<std::size_t>(3 * whole->num_tris);
    if (s.aa_tris.size() != n || std::memcmp(s.aa_tris.data(), whole->tris, n * sizeof(std::int32_t)) != 0) {
      raster::detail::check_triangles(whole->tris, whole->num_tris, s.num_vertices, "vulkan antialias");
      s.aa_tris.assign(whole->tris, whole->tris + n);
      s.aa_tris_on_device = false;
    }
    if (!s.aa_tris_on_device) {
      whole_bytes = n * sizeof(std::int32_t);
      s.reserve(kAaTris, whole_bytes);
    }
  }
  // The caller's topology unless kNeighbour holds it (by serial; 0: always
  // uploaded), else the triangles' own unless kNeighbour holds it.
  const bool upload_topology =
      topology ? topology->serial() == 0 || topology->serial() != s.neighbour_serial : !s.topology_ready;
  std::vector<std::int32_t> neighbours;
  if (upload_topology) {
    neighbours = topology ? std::vector<std::int32_t>(topology->neighbour().begin(), topology->neighbour().end())
                          : neighbours_of(s.tris);
    s.topology_ready = false;  // kNeighbour is replaced below: it holds neither until the upload is done
    s.neighbour_serial = 0;
  }
  const std::size_t neighbour_bytes = neighbours.size() * sizeof(std::int32_t);
  s.reserve(kAaImage, image_bytes);
  s.reserve(kAaOut, image_bytes);
  s.reserve(kAaPairs, 2 * px * kPairBytes);
  if (upload_topology) s.reserve(kNeighbour, neighbour_bytes);
  s.upload.reserve(s.dev, upload_image + neighbour_bytes + whole_bytes, true);
  s.download.reserve(s.dev, out ? image_bytes : 0, true);
  char* staged = static_cast<char*>(s.upload.mapped());
  if (upload_image) std::memcpy(staged, image, upload_image);
  if (neighbour_bytes) std::memcpy(staged + upload_image, neighbours.data(), neighbour_bytes);
  if (whole_bytes) std::memcpy(staged + upload_image + neighbour_bytes, whole->tris, whole_bytes);
  // Bindings (antialias_common.glsl): 0 clip, 1 tris (the whole list's for a range), 2 verts, 3 tri_id,
  // 4 rast (z/w: the depth), 5 neighbours, 6 image, 7 pairs, 9 out.
  const Role list = whole ? kAaTris : kTris;
  const VkDescriptorSet set = s.bind(s.aa_forward_set, {{0, kClip}, {1, list}, {2, kVerts}, {3, kTriId}, {4, kRast},
                                                        {5, kNeighbour}, {6, kAaImage}, {7, kAaPairs}, {9, kAaOut}});
  const std::int32_t first = whole ? static_cast<std::int32_t>(whole->first) : 0;
  const AntialiasPush push{s.width, s.height, static_cast<std::int32_t>(s.num_vertices), first, channels, 0,
                           s.y_up ? 1 : 0, visibility ? 1 : 0};
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 5);
    if (image)
      copy(cb, s.upload.handle(), 0, s[kAaImage].handle(), 0, image_bytes);
    else
      copy(cb, s[kInterpolated].handle(), 0, s[kAaImage].handle(), 0, image_bytes);
    copy(cb, s.upload.handle(), upload_image, s[kNeighbour].handle(), 0, neighbour_bytes);
    copy(cb, s.upload.handle(), upload_image + neighbour_bytes, s[kAaTris].handle(), 0, whole_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.use(cb, set);
    dispatch(cb, s.k, visibility ? s.k.visibility_pairs : s.k.antialias_pairs, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
    dispatch(cb, s.k, s.k.antialias_forward, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 3);
    if (out) copy(cb, s[kAaOut].handle(), 0, s.download.handle(), 0, image_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 4);
  };
  s.ticket = s.dev.run(record, [&s, out, image_bytes] {
    if (out) std::memcpy(out, s.download.mapped(), image_bytes);
  });
  if (upload_topology) {
    if (topology)
      s.neighbour_serial = topology->serial();
    else
      s.topology_ready = true;
    ++s.topology_uploads.uploads;
    s.topology_uploads.bytes += static_cast<std::int64_t>(neighbour_bytes);
  }
  if (whole_bytes) {
    s.aa_tris_on_device = true;
    ++s.triangle_uploads.uploads;
    s.triangle_uploads.bytes += static_cast<std::int64_t>(whole_bytes);
  }
  s.aa_channels = channels;
  s.aa_serial = ++g_call_serial;
  s.aa_visibility = visibility;
  s.aa_whole = whole != nullptr;
  s.aa_first = first;
  return s.times();
}

GpuTimes Frame::antialias_backward(const float* grad_out, float* grad_image, float* grad_clip) {
  State& s = *state_;
  if (s.aa_channels < 0) throw ValueError("vulkan antialias_backward: the frame has no antialias to differentiate");
  if (!grad_out) throw ValueError("vulkan antialias_backward: grad_out is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  const std::int64_t N = s.num_vertices, C = s.aa_channels, px = s.pixels();
  const std::size_t image_bytes = static_cast<std::size_t>(px * C) * sizeof(float);
  const std::size_t clip_bytes = static_cast<std::size_t>(N) * 4 * sizeof(float);
  // Screen x, y per vertex; and z_ndc, which visibility_antialias's crossings move.
  const std::size_t sums = static_cast<std::size_t>(N) * (s.aa_visibility ? 3 : 2);
  s.reserve(kAaGradOut, image_bytes);
  s.reserve(kAaGradImage, image_bytes);
  s.reserve(kSums, sums * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));  // fixed_point.glsl reads two slots
  s.reserve(kFinished, clip_bytes);
  s.upload.reserve(s.dev, image_bytes, true);
  s.download.reserve(s.dev, image_bytes + clip_bytes, true);
  std::memcpy(s.upload.mapped(), grad_out, image_bytes);
  // Bindings: 0 clip, 1 tris (a crossing's vertices: the list the forward read), 2 verts, 3 grad_out,
  // 4 grad_image, 5 screen sums, 6 image, 7 pairs, 8 largest, 9 grad_clip.
  const VkDescriptorSet set =
      s.bind(s.aa_backward_set, {{0, kClip}, {1, s.aa_whole ? kAaTris : kTris}, {2, kVerts}, {3, kAaGradOut},
                                 {4, kAaGradImage}, {5, kSums}, {6, kAaImage}, {7, kAaPairs}, {8, kLargest},
                                 {9, kFinished}});
  AntialiasPush push{s.width, s.height, static_cast<std::int32_t>(N), s.aa_first, static_cast<std::int32_t>(C), 0,
                     s.y_up ? 1 : 0, s.aa_visibility ? 1 : 0};
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kAaGradOut].handle(), 0, image_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, sums, kLargest, s.k.antialias_backward, push,
                         s.k.antialias_finish, push, N);
    copy(cb, s[kAaGradImage].handle(), 0, s.download.handle(), 0, image_bytes);
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), image_bytes, clip_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  };
  s.ticket = s.dev.run(record, [&s, grad_image, grad_clip, px, C, N] {
    const float* got = static_cast<const float*>(s.download.mapped());
    add_to(grad_image, got, px * C);
    add_to(grad_clip, got + px * C, N * 4);
  });
  return s.times();
}

std::uint64_t Frame::interpolate_serial() const {
  std::lock_guard<std::mutex> lock(state_->dev.mutex);
  return state_->ip_serial;
}

std::uint64_t Frame::antialias_serial() const {
  std::lock_guard<std::mutex> lock(state_->dev.mutex);
  return state_->aa_serial;
}

Uploads Frame::topology_uploads() const {
  std::lock_guard<std::mutex> lock(state_->dev.mutex);
  return state_->topology_uploads;
}

Uploads Frame::triangle_uploads() const {
  std::lock_guard<std::mutex> lock(state_->dev.mutex);
  return state_->triangle_uploads;
}

void Frame::discard_gbuffer_gradient() {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.grad_rast = s.grad_db = false;  // stale: zeroed on first use, read only where flagged
}

GpuTimes Frame::rasterize_backward(const float* grad_rast, const float* grad_db, float* grad_clip) {
  State& s = *state_;
  if (!s.rasterized) throw ValueError("vulkan rasterize_backward: the frame has no G-buffer (call rasterize first)");
  if (grad_db && !s.derivatives)
    throw ValueError("vulkan rasterize_backward: grad_db given, but the G-buffer was made without derivatives");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.settle();
  const std::int64_t N = s.num_vertices, px = s.pixels();
  const std::size_t plane = static_cast<std::size_t>(px) * 4 * sizeof(float);
  const std::size_t host_bytes[2] = {grad_rast ? plane : 0, grad_db ? plane : 0};
  const std::size_t sums = static_cast<std::size_t>(N) * 4;
  const std::int32_t flags = (s.grad_rast ? kDeviceRast : 0) | (s.grad_db ? kDeviceDb : 0) |
                             (grad_rast ? kHostRast : 0) | (grad_db ? kHostDb : 0);
  s.reserve(kHostGradGBuffer, 2 * plane);
  s.reserve(kGradGBuffer, 2 * plane);  // read only where flagged
  s.reserve(kSums, sums * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));
  s.reserve(kFinished, sums * sizeof(float));
  s.upload.reserve(s.dev, host_bytes[0] + host_bytes[1], true);
  s.download.reserve(s.dev, sums * sizeof(float), true);
  if (grad_rast) std::memcpy(s.upload.mapped(), grad_rast, plane);
  if (grad_db) std::memcpy(static_cast<char*>(s.upload.mapped()) + host_bytes[0], grad_db, plane);
  // Bindings: 0 clip, 1 tris, 2 the host's G-buffer gradient, 3 tri_id, 4 the device's, 7 sums,
  // 8 largest; the finish: 7 sums, 8 largest, 9 dL/dclip.
  const VkDescriptorSet set =
      s.bind(s.raster_backward_set, {{0, kClip}, {1, kTris}, {2, kHostGradGBuffer}, {3, kTriId}, {4, kGradGBuffer},
                                     {7, kSums}, {8, kLargest}});
  const VkDescriptorSet finish_set = s.bind(s.finish_set, {{7, kSums}, {8, kLargest}, {9, kFinished}});
  // Per element at most one contribution per pixel and vertex slot.
  const std::int32_t count = static_cast<std::int32_t>(3 * px);  // px <= 2^28 (check_image_size)
  const GBufferPush push{s.width, s.height, static_cast<std::int32_t>(N), static_cast<std::int32_t>(s.num_tris),
                         0, s.y_up ? 1 : 0, flags, count};
  const FinishPush finish{static_cast<std::int32_t>(sums), static_cast<std::int32_t>(sums), count, {}};
  auto record = [&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kHostGradGBuffer].handle(), 0, host_bytes[0]);
    copy(cb, s.upload.handle(), host_bytes[0], s[kHostGradGBuffer].handle(), plane, host_bytes[1]);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, sums, kLargest, s.k.gbuffer_backward, push, s.k.fixed_point_finish, finish,
                         static_cast<std::int64_t>(sums), finish_set);
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), 0, sums * sizeof(float));
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  };
  s.ticket = s.dev.run(record, [&s, grad_clip, N] {
    add_to(grad_clip, static_cast<const float*>(s.download.mapped()), 4 * N);
  });
  s.grad_rast = s.grad_db = false;  // consumed
  return s.times();
}

}  // namespace gr::vulkan
