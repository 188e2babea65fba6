// The Frame's calls: each records its uploads, passes and downloads into one
// command buffer with timestamps between them, submits it and waits.
#include "raster/vulkan/frame.h"

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

// Bytes of one antialias pair slot (struct Pair, antialias_common.glsl): t, a, b.
constexpr std::size_t kPairBytes = 16;

// Workgroups of raster_large; their invocations take the listed chunks in turn.
constexpr std::uint32_t kLargeWorkgroups = 1024;
// Timestamps of the call that stamps the most (rasterize).
constexpr std::uint32_t kMaxTimestamps = 8;

struct RasterPush {
  std::int32_t width, height, num_vertices, num_tris, cull, pass, y_up, flags;
};
struct InterpolatePush {
  std::int32_t width, height, num_vertices, num_tris, channels, pass, perspective, y_up;
};
struct FinishPush {
  std::int32_t count, split, pixels, pad[5];
};
struct AntialiasPush {
  std::int32_t width, height, num_vertices, num_tris, channels, pass, y_up, pad;
};
static_assert(sizeof(RasterPush) == kPushBytes && sizeof(InterpolatePush) == kPushBytes &&
                  sizeof(FinishPush) == kPushBytes && sizeof(AntialiasPush) == kPushBytes,
              "push constant blocks");

// The frame's buffers by role (device-local), and two host-visible staging buffers.
enum Role {
  kClip, kTris, kVerts, kKeys, kIds, kLarge, kTriId, kUv, kDepth,  // mesh and G-buffer
  kAttr, kInterpolated, kGradOut, kGradUv,  // interpolate
  kSums, kLargest, kFinished,  // an adjoint's fixed-point sums, their scales, its result
  kGradUvIn, kGradDepthIn,  // rasterize_backward's incoming gradients
  kNeighbour, kAaImage, kAaOut, kAaPairs, kAaGradOut, kAaGradImage,  // antialias
  kRoles
};

}  // namespace

struct Frame::State {
  State(Device::Impl& dev, Kernels& k)
      : dev(dev), k(k), raster_set(dev, k.pipelines), forward_set(dev, k.pipelines), backward_set(dev, k.pipelines),
        raster_backward_set(dev, k.pipelines), aa_forward_set(dev, k.pipelines), aa_backward_set(dev, k.pipelines),
        timestamps(dev, kMaxTimestamps) {}

  Device::Impl& dev;
  Kernels& k;
  Buffer buffers[kRoles];
  Buffer upload, download;
  DescriptorSet raster_set, forward_set, backward_set, raster_backward_set, aa_forward_set, aa_backward_set;
  Timestamps timestamps;
  // What the last rasterize and interpolate were given.
  int width = 0, height = 0;
  std::int64_t num_vertices = 0, num_tris = 0;
  bool y_up = false, rasterized = false;
  std::int64_t channels = -1;
  bool perspective = true;
  int aa_channels = -1;  // of the last antialias (-1: none since the last rasterize)
  // The triangles the device's edge topology (kNeighbour) is for, once topology_ready.
  std::vector<std::int32_t> tris;
  bool topology_ready = false;

  Buffer& operator[](Role r) { return buffers[r]; }
  std::int64_t pixels() const { return static_cast<std::int64_t>(width) * height; }
  void reserve(Role r, std::size_t bytes) { buffers[r].reserve(dev, bytes, false); }
  VkDescriptorSet bind(DescriptorSet& set, std::initializer_list<std::pair<std::uint32_t, Role>> bindings) {
    VkBuffer handles[kBindings] = {};
    for (const auto& [binding, role] : bindings) handles[binding] = buffers[role].handle();
    return set.bind(handles);
  }
  // Keeps the host copy of the triangles; the topology is stale when they changed.
  void note_triangles(const std::int32_t* t, std::int64_t num_tris) {
    const std::size_t n = static_cast<std::size_t>(3 * num_tris);
    if (tris.size() == n && (n == 0 || std::memcmp(tris.data(), t, n * sizeof(std::int32_t)) == 0)) return;
    tris.assign(t, t + n);
    topology_ready = false;
  }
  void use(VkCommandBuffer cb, VkDescriptorSet set) {
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipelines.layout(), 0, 1, &set, 0, nullptr);
  }
  // The adjoints' passes (fixed_point.glsl), after stamp 1: zero `count`
  // fixed-point sums and the two largest magnitudes; `pipeline` over the
  // pixels with pass 0 (magnitudes), then 1 (sums); `finish` over
  // `finish_items`. Stamps 2, 3 and 4 after them.
  template <class Push, class FinishPush>
  void fixed_point_passes(VkCommandBuffer cb, VkDescriptorSet set, Role sums, std::size_t count, Role largest,
                          VkPipeline pipeline, Push push, VkPipeline finish, const FinishPush& finish_push,
                          std::int64_t finish_items) {
    vkCmdFillBuffer(cb, buffers[sums].handle(), 0, count * sizeof(std::int64_t), 0u);
    vkCmdFillBuffer(cb, buffers[largest].handle(), 0, 2 * sizeof(std::uint64_t), 0u);
    barrier(cb);
    use(cb, set);
    for (std::int32_t pass = 0; pass < 2; ++pass) {
      push.pass = pass;
      dispatch(cb, k, pipeline, &push, pixels(), 256);
      barrier(cb);
      timestamps.stamp(cb, 2 + pass);
    }
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
  return std::vector<std::int32_t>(topo.neighbour.begin(), topo.neighbour.end());
}

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
  state_.reset();
}

GpuTimes Frame::rasterize(const raster::RasterParams<float>& p, const GpuRasterOptions& options, std::int32_t* tri_id,
                      float* uv, float* depth) {
  if (p.floor_id || p.floor_z)
    throw ValueError("vulkan rasterize: depth peeling (floor_id, floor_z) is not on the GPU yet");
  if (options.small_box < 1)
    throw ValueError("vulkan rasterize: small_box must be at least 1, got " + std::to_string(options.small_box));
  check_raster_params(p);
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.rasterized = false;
  s.width = p.settings.width;
  s.height = p.settings.height;
  s.num_vertices = p.num_vertices;
  s.num_tris = p.num_tris;
  s.y_up = options.y_up || p.settings.y_up;
  s.channels = -1;
  s.aa_channels = -1;
  s.note_triangles(p.tris, p.num_tris);
  const std::size_t px = static_cast<std::size_t>(s.pixels());
  const std::size_t clip_bytes = static_cast<std::size_t>(p.num_vertices) * 4 * sizeof(float);
  const std::size_t tri_bytes = static_cast<std::size_t>(p.num_tris) * 3 * sizeof(std::int32_t);
  const std::size_t out_bytes[3] = {tri_id ? px * sizeof(std::int32_t) : 0, uv ? px * 2 * sizeof(float) : 0,
                                    depth ? px * sizeof(float) : 0};
  s.reserve(kClip, clip_bytes);
  s.reserve(kTris, tri_bytes);
  s.reserve(kVerts, static_cast<std::size_t>(p.num_vertices) * 32);
  s.reserve(kKeys, px * sizeof(std::uint64_t));
  s.reserve(kIds, px * sizeof(std::int32_t));
  s.reserve(kLarge, (static_cast<std::size_t>(p.num_tris) + 1) * 2 * sizeof(std::uint32_t));
  s.reserve(kTriId, px * sizeof(std::int32_t));
  s.reserve(kUv, px * 2 * sizeof(float));
  s.reserve(kDepth, px * sizeof(float));
  s.upload.reserve(s.dev, clip_bytes + tri_bytes, true);
  s.download.reserve(s.dev, out_bytes[0] + out_bytes[1] + out_bytes[2], true);
  if (clip_bytes) std::memcpy(s.upload.mapped(), p.clip, clip_bytes);
  if (tri_bytes) std::memcpy(static_cast<char*>(s.upload.mapped()) + clip_bytes, p.tris, tri_bytes);

  // Raster shaders' bindings: 0 clip, 1 tris, 2 verts, 3 keys, 4 ids, 5 large list, 6-8 the G-buffer.
  const VkDescriptorSet set = s.bind(s.raster_set, {{0, kClip}, {1, kTris}, {2, kVerts}, {3, kKeys}, {4, kIds},
                                                    {5, kLarge}, {6, kTriId}, {7, kUv}, {8, kDepth}});
  const VkPipeline small = s.k.raster_small(options.small_box);
  RasterPush push{s.width, s.height, static_cast<std::int32_t>(p.num_vertices), static_cast<std::int32_t>(p.num_tris),
                  p.settings.cull == raster::Cull::Back ? 1 : p.settings.cull == raster::Cull::Front ? -1 : 0,
                  0, s.y_up ? 1 : 0, 0};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 8);
    copy(cb, s.upload.handle(), 0, s[kClip].handle(), 0, clip_bytes);
    copy(cb, s.upload.handle(), clip_bytes, s[kTris].handle(), 0, tri_bytes);
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
    const Role outs[3] = {kTriId, kUv, kDepth};
    std::size_t offset = 0;
    for (int i = 0; i < 3; ++i) {
      copy(cb, s[outs[i]].handle(), 0, s.download.handle(), offset, out_bytes[i]);
      offset += out_bytes[i];
    }
    barrier(cb);
    s.timestamps.stamp(cb, 7);
  });
  const char* from = static_cast<const char*>(s.download.mapped());
  void* to[3] = {tri_id, uv, depth};
  for (int i = 0; i < 3; ++i) {
    if (out_bytes[i]) std::memcpy(to[i], from, out_bytes[i]);
    from += out_bytes[i];
  }
  s.rasterized = true;
  return s.timestamps.read();
}

GpuTimes Frame::interpolate(const float* attr, std::int64_t channels, bool perspective, float* out) {
  State& s = *state_;
  if (!s.rasterized) throw ValueError("vulkan interpolate: the frame has no G-buffer (call rasterize first)");
  check_channels(channels, s.pixels(), "vulkan interpolate");
  if (!attr && s.num_vertices * channels > 0) throw ValueError("vulkan interpolate: attr is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.channels = channels;
  s.perspective = perspective;
  const std::size_t attr_bytes = static_cast<std::size_t>(s.num_vertices * channels) * sizeof(float);
  const std::size_t out_bytes = static_cast<std::size_t>(s.pixels() * channels) * sizeof(float);
  s.reserve(kAttr, attr_bytes);
  s.reserve(kInterpolated, out_bytes);
  s.upload.reserve(s.dev, attr_bytes, true);
  s.download.reserve(s.dev, out ? out_bytes : 0, true);
  if (attr_bytes) std::memcpy(s.upload.mapped(), attr, attr_bytes);
  // Interpolate shaders' bindings: 0 clip, 1 tris, 2 attr, 3 tri_id, 4 uv, 5 out.
  const VkDescriptorSet set =
      s.bind(s.forward_set, {{0, kClip}, {1, kTris}, {2, kAttr}, {3, kTriId}, {4, kUv}, {5, kInterpolated}});
  const InterpolatePush push{s.width, s.height, static_cast<std::int32_t>(s.num_vertices),
                             static_cast<std::int32_t>(s.num_tris), static_cast<std::int32_t>(channels),
                             0, perspective ? 1 : 0, s.y_up ? 1 : 0};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 4);
    copy(cb, s.upload.handle(), 0, s[kAttr].handle(), 0, attr_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.use(cb, set);
    if (channels > 0) dispatch(cb, s.k, s.k.interpolate_forward, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
    if (out) copy(cb, s[kInterpolated].handle(), 0, s.download.handle(), 0, out_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 3);
  });
  if (out && out_bytes) std::memcpy(out, s.download.mapped(), out_bytes);
  return s.timestamps.read();
}

GpuTimes Frame::interpolate_backward(const float* grad_out, float* grad_attr, float* grad_clip, float* grad_uv) {
  State& s = *state_;
  if (s.channels < 0) throw ValueError("vulkan interpolate_backward: the frame has no interpolate to differentiate");
  if (!grad_out) throw ValueError("vulkan interpolate_backward: grad_out is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  const std::int64_t N = s.num_vertices, C = s.channels, px = s.pixels();
  const std::size_t grad_bytes = static_cast<std::size_t>(px * C) * sizeof(float);
  const std::size_t sums = static_cast<std::size_t>(N * C + N * 4);
  const std::size_t uv_bytes = static_cast<std::size_t>(px) * 2 * sizeof(float);
  s.reserve(kGradOut, grad_bytes);
  s.reserve(kGradUv, uv_bytes);
  s.reserve(kSums, sums * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));
  s.reserve(kFinished, sums * sizeof(float));
  s.upload.reserve(s.dev, grad_bytes, true);
  s.download.reserve(s.dev, sums * sizeof(float) + uv_bytes, true);
  if (grad_bytes) std::memcpy(s.upload.mapped(), grad_out, grad_bytes);
  // Bindings: 0-4 as the forward, 5 grad_out, 6 grad_uv, 7 sums, 8 largest magnitudes, 9 finished sums.
  const VkDescriptorSet set = s.bind(s.backward_set, {{0, kClip}, {1, kTris}, {2, kAttr}, {3, kTriId}, {4, kUv},
                                                      {5, kGradOut}, {6, kGradUv}, {7, kSums}, {8, kLargest},
                                                      {9, kFinished}});
  InterpolatePush push{s.width, s.height, static_cast<std::int32_t>(N), static_cast<std::int32_t>(s.num_tris),
                       static_cast<std::int32_t>(C), 0, s.perspective ? 1 : 0, s.y_up ? 1 : 0};
  const FinishPush finish{static_cast<std::int32_t>(sums), static_cast<std::int32_t>(N * C),
                          static_cast<std::int32_t>(px), {}};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kGradOut].handle(), 0, grad_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, sums, kLargest, s.k.interpolate_backward, push, s.k.fixed_point_finish,
                         finish, static_cast<std::int64_t>(sums));
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), 0, sums * sizeof(float));
    copy(cb, s[kGradUv].handle(), 0, s.download.handle(), sums * sizeof(float), uv_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  });
  const float* got = static_cast<const float*>(s.download.mapped());
  add_to(grad_attr, got, N * C);
  add_to(grad_clip, got + N * C, N * 4);
  add_to(grad_uv, got + sums, 2 * px);
  return s.timestamps.read();
}

GpuTimes Frame::antialias(const float* image, int channels, float* out) {
  State& s = *state_;
  if (!s.rasterized) throw ValueError("vulkan antialias: the frame has no G-buffer (call rasterize first)");
  if (channels < 1) throw ValueError("vulkan antialias: channels must be at least 1, got " + std::to_string(channels));
  check_channels(channels, s.pixels(), "vulkan antialias");
  if (!image && s.channels != channels)
    throw ValueError("vulkan antialias: no image given, and the last interpolate's output has " +
                     (s.channels < 0 ? std::string("not been made") : std::to_string(s.channels) + " channels") +
                     ", not " + std::to_string(channels));
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  s.aa_channels = -1;
  const std::size_t px = static_cast<std::size_t>(s.pixels());
  const std::size_t image_bytes = px * static_cast<std::size_t>(channels) * sizeof(float);
  // No image: the last interpolate's output, copied on the device.
  const std::size_t upload_image = image ? image_bytes : 0;
  // The topology only when the triangles changed since it was uploaded.
  const std::vector<std::int32_t> neighbours = s.topology_ready ? std::vector<std::int32_t>() : neighbours_of(s.tris);
  const std::size_t neighbour_bytes = neighbours.size() * sizeof(std::int32_t);
  s.reserve(kAaImage, image_bytes);
  s.reserve(kAaOut, image_bytes);
  s.reserve(kAaPairs, 2 * px * kPairBytes);
  if (!s.topology_ready) s.reserve(kNeighbour, neighbour_bytes);
  s.upload.reserve(s.dev, upload_image + neighbour_bytes, true);
  s.download.reserve(s.dev, out ? image_bytes : 0, true);
  if (upload_image) std::memcpy(s.upload.mapped(), image, upload_image);
  if (neighbour_bytes) std::memcpy(static_cast<char*>(s.upload.mapped()) + upload_image, neighbours.data(), neighbour_bytes);
  // Bindings (antialias_common.glsl): 0 clip, 1 tris, 2 verts, 3 tri_id, 4 depth, 5 neighbours, 6 image,
  // 7 pairs, 9 out.
  const VkDescriptorSet set = s.bind(s.aa_forward_set, {{0, kClip}, {1, kTris}, {2, kVerts}, {3, kTriId}, {4, kDepth},
                                                        {5, kNeighbour}, {6, kAaImage}, {7, kAaPairs}, {9, kAaOut}});
  const AntialiasPush push{s.width, s.height, static_cast<std::int32_t>(s.num_vertices),
                           static_cast<std::int32_t>(s.num_tris), channels, 0, s.y_up ? 1 : 0, 0};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 5);
    if (image)
      copy(cb, s.upload.handle(), 0, s[kAaImage].handle(), 0, image_bytes);
    else
      copy(cb, s[kInterpolated].handle(), 0, s[kAaImage].handle(), 0, image_bytes);
    copy(cb, s.upload.handle(), upload_image, s[kNeighbour].handle(), 0, neighbour_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.use(cb, set);
    dispatch(cb, s.k, s.k.antialias_pairs, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 2);
    dispatch(cb, s.k, s.k.antialias_forward, &push, s.pixels(), 256);
    barrier(cb);
    s.timestamps.stamp(cb, 3);
    if (out) copy(cb, s[kAaOut].handle(), 0, s.download.handle(), 0, image_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 4);
  });
  s.topology_ready = true;
  s.aa_channels = channels;
  if (out) std::memcpy(out, s.download.mapped(), image_bytes);
  return s.timestamps.read();
}

GpuTimes Frame::antialias_backward(const float* grad_out, float* grad_image, float* grad_clip) {
  State& s = *state_;
  if (s.aa_channels < 0) throw ValueError("vulkan antialias_backward: the frame has no antialias to differentiate");
  if (!grad_out) throw ValueError("vulkan antialias_backward: grad_out is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  const std::int64_t N = s.num_vertices, C = s.aa_channels, px = s.pixels();
  const std::size_t image_bytes = static_cast<std::size_t>(px * C) * sizeof(float);
  const std::size_t clip_bytes = static_cast<std::size_t>(N) * 4 * sizeof(float);
  s.reserve(kAaGradOut, image_bytes);
  s.reserve(kAaGradImage, image_bytes);
  s.reserve(kSums, static_cast<std::size_t>(N) * 2 * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));  // fixed_point.glsl reads two slots
  s.reserve(kFinished, clip_bytes);
  s.upload.reserve(s.dev, image_bytes, true);
  s.download.reserve(s.dev, image_bytes + clip_bytes, true);
  std::memcpy(s.upload.mapped(), grad_out, image_bytes);
  // Bindings: 0 clip, 2 verts, 3 grad_out, 4 grad_image, 5 screen sums, 6 image, 7 pairs, 8 largest, 9 grad_clip.
  const VkDescriptorSet set =
      s.bind(s.aa_backward_set, {{0, kClip}, {2, kVerts}, {3, kAaGradOut}, {4, kAaGradImage}, {5, kSums},
                                 {6, kAaImage}, {7, kAaPairs}, {8, kLargest}, {9, kFinished}});
  AntialiasPush push{s.width, s.height, static_cast<std::int32_t>(N), static_cast<std::int32_t>(s.num_tris),
                     static_cast<std::int32_t>(C), 0, s.y_up ? 1 : 0, 0};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kAaGradOut].handle(), 0, image_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, static_cast<std::size_t>(N) * 2, kLargest, s.k.antialias_backward, push,
                         s.k.antialias_finish, push, N);
    copy(cb, s[kAaGradImage].handle(), 0, s.download.handle(), 0, image_bytes);
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), image_bytes, clip_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  });
  const float* got = static_cast<const float*>(s.download.mapped());
  add_to(grad_image, got, px * C);
  add_to(grad_clip, got + px * C, N * 4);
  return s.timestamps.read();
}

GpuTimes Frame::rasterize_backward(const float* grad_uv, const float* grad_depth, float* grad_clip) {
  State& s = *state_;
  if (!s.rasterized) throw ValueError("vulkan rasterize_backward: the frame has no G-buffer (call rasterize first)");
  if (!grad_uv) throw ValueError("vulkan rasterize_backward: grad_uv is missing");
  std::lock_guard<std::mutex> lock(s.dev.mutex);
  const std::int64_t N = s.num_vertices, px = s.pixels();
  const std::size_t uv_bytes = static_cast<std::size_t>(px) * 2 * sizeof(float);
  const std::size_t depth_bytes = grad_depth ? static_cast<std::size_t>(px) * sizeof(float) : 0;
  const std::size_t sums = static_cast<std::size_t>(N * 3 + N * 4), out_bytes = static_cast<std::size_t>(N) * 4 * 4;
  s.reserve(kGradUvIn, uv_bytes);
  s.reserve(kGradDepthIn, depth_bytes);
  s.reserve(kSums, sums * sizeof(std::int64_t));
  s.reserve(kLargest, 2 * sizeof(std::uint64_t));
  s.reserve(kFinished, out_bytes);
  s.upload.reserve(s.dev, uv_bytes + depth_bytes, true);
  s.download.reserve(s.dev, out_bytes, true);
  std::memcpy(s.upload.mapped(), grad_uv, uv_bytes);
  if (depth_bytes) std::memcpy(static_cast<char*>(s.upload.mapped()) + uv_bytes, grad_depth, depth_bytes);
  // Bindings: 0 clip, 1 tris, 2 verts, 3 tri_id, 4 grad_uv, 5 grad_depth, 7 sums, 8 largest, 9 dL/dclip.
  const VkDescriptorSet set =
      s.bind(s.raster_backward_set, {{0, kClip}, {1, kTris}, {2, kVerts}, {3, kTriId}, {4, kGradUvIn},
                                     {5, kGradDepthIn}, {7, kSums}, {8, kLargest}, {9, kFinished}});
  RasterPush push{s.width, s.height, static_cast<std::int32_t>(N), static_cast<std::int32_t>(s.num_tris), 0, 0,
                  s.y_up ? 1 : 0, grad_depth ? 1 : 0};
  s.dev.run([&](VkCommandBuffer cb) {
    s.timestamps.begin(cb, 6);
    copy(cb, s.upload.handle(), 0, s[kGradUvIn].handle(), 0, uv_bytes);
    copy(cb, s.upload.handle(), uv_bytes, s[kGradDepthIn].handle(), 0, depth_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 1);
    s.fixed_point_passes(cb, set, kSums, sums, kLargest, s.k.rasterize_backward, push, s.k.rasterize_backward_finish,
                         push, N);
    copy(cb, s[kFinished].handle(), 0, s.download.handle(), 0, out_bytes);
    barrier(cb);
    s.timestamps.stamp(cb, 5);
  });
  const float* got = static_cast<const float*>(s.download.mapped());
  add_to(grad_clip, got, 4 * N);
  return s.timestamps.read();
}

}  // namespace gr::vulkan
