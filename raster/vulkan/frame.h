// A render kept on a Vulkan device: one mesh's clip positions and triangles,
// the G-buffer rasterized from them, and the buffers of the ops run on it, so
// that interpolate (and its adjoint) read the G-buffer without a round trip.
// Host arrays cross at each call: inputs are uploaded, and outputs are
// downloaded only where the caller passes a pointer. Each call returns where
// its time went (device timestamps; docs/gpu.md).
//
// Results: rasterize gives the CPU kernels' coverage and G-buffer
// (raster::rasterize_forward's tri_id, then raster::barycentric_gbuffer_forward's
// rast and rast_db) bit for bit; interpolate the CPU kernel's values
// (raster/barycentric_interpolate.h, the same double expressions: bit for bit
// on lavapipe, at most an ulp of float apart elsewhere); the adjoints' sums
// over pixels are taken in 64-bit fixed point (exact and order-independent,
// so bit-identical run to run; resolution about 2^-61 x pixels x the largest
// contribution), within 1e-12 of the CPU's double sums relative to the
// largest gradient. antialias gives the CPU kernel's pairs (the same
// silhouette walk in double) and blends, bit for bit; its adjoint sums the
// edge vertices' screen gradients in fixed point (the same resolution)
// before the projection adjoint. visibility_antialias likewise (its pairs
// and blends bit for bit; the crossings' six vertices' screen x, y and z_ndc
// summed in fixed point).
//
// A Frame is used by one thread at a time; Frames on one device share its
// queue (calls are serialized). Between a backend's begin_deferred and
// end_deferred (raster::DeferredCalls) a call may return before its outputs
// are written (at the end, in call order) and its GpuTimes are then empty;
// inputs are read during the call.
#pragma once

#include <cstdint>
#include <memory>

#include "raster/antialias.h"
#include "raster/rasterize.h"
#include "raster/vulkan/device.h"
#include "raster/vulkan/rasterize.h"

namespace gr::vulkan {

// What a Frame uploaded of one kind of mesh data (the edge topology, the
// triangle list): how many uploads and their bytes, for tests and profiling.
struct Uploads {
  std::int64_t uploads = 0;
  std::int64_t bytes = 0;
};

// The whole triangle list a range mode G-buffer was rasterized from part of
// (Frame::antialias): the frame's triangles are rows first..first + M - 1 of
// tris (num_tris rows), and its ids number them from 1.
struct WholeTriangles {
  const std::int32_t* tris = nullptr;
  std::int64_t num_tris = 0;
  std::int64_t first = 0;
};

class Frame {
 public:
  explicit Frame(std::shared_ptr<Device> device);
  ~Frame();
  Frame(const Frame&) = delete;
  Frame& operator=(const Frame&) = delete;

  // The coverage (rasterize_forward's tri_id, H x W) and nvdiffrast's
  // G-buffer of raster::barycentric_gbuffer_forward (id_offset 0): rast
  // (H x W x 4: u, v, z/w, id; zeros on background) and, with
  // options.derivatives, db (H x W x 4: rast_db). Row 0 at the bottom with
  // options.y_up or p.settings.y_up (as the CPU kernels' y_up). It stays on the
  // device and is downloaded into the arrays given (each may be null; db
  // needs options.derivatives). Checks p as the CPU op does (ValueError /
  // IndexError naming the problem): image size, indices in range, finite
  // clip; and what the shaders' 32-bit indices allow (at most 2^31 / 4
  // vertices, 2^31 / 3 triangles). pass_ms: clear, project, depth pass, id
  // pass, resolve, G-buffer.
  // Depth peeling as on the CPU: p.floor_id and p.floor_z (both or neither)
  // keep per pixel only triangles strictly behind the previous layer's
  // (depth, id) key; key_depth (H x W, if not null) receives the winning
  // depth in double (+inf on background), the next layer's floor_z.
  GpuTimes rasterize(const raster::RasterParams<float>& p, const GpuRasterOptions& options = {},
                     std::int32_t* tri_id = nullptr, float* rast = nullptr, float* db = nullptr,
                     double* key_depth = nullptr);

  // A G-buffer made elsewhere (the ops keep theirs on the host), in place of
  // rasterize's, for interpolate, antialias and rasterize_backward: p's clip,
  // triangles, image size and y_up (or options.y_up), its coverage tri_id
  // (H x W, ids in [0, M]) and, each may be null (zeros then), uv (H x W x
  // uv_stride: u, v in channels 0 and 1), depth (H x W: z/w, read on covered
  // pixels only) and db (H x W x 4: rast_db). options.derivatives marks the
  // frame as having rast_db (interpolate's derivatives, rasterize_backward's
  // grad_db). Checks p as rasterize does, and the ids. The frame's own edge
  // topology is rebuilt at the next antialias without one (a caller's
  // topology the device holds stays: antialias knows it by its serial).
  // pass_ms: upload, project.
  GpuTimes load_gbuffer(const raster::RasterParams<float>& p, const GpuRasterOptions& options,
                        const std::int32_t* tri_id, const float* uv, int uv_stride, const float* depth,
                        const float* db);

  // raster::rasterize_forward's own outputs: tri_id and the coverage
  // kernel's screen-space uv (H x W x 2) and depth (H x W), for
  // vulkan::rasterize_forward (a RasterBackend). Makes no G-buffer: the frame
  // then has none for interpolate and antialias. pass_ms: clear, project,
  // depth pass, id pass, resolve.
  GpuTimes rasterize_coverage(const raster::RasterParams<float>& p, const GpuRasterOptions& options,
                              std::int32_t* tri_id, float* uv, float* depth, double* key_depth = nullptr);

  // raster::barycentric_interpolate_forward of attr (num_vertices x
  // channels) over the last rasterize's G-buffer (zeros on background); out
  // (H x W x channels) if not null. diff (num_diff channel indices in
  // [0, channels), may repeat; needs a rasterize with options.derivatives):
  // their screen derivatives, out_da (H x W x 2 num_diff: d/dx, d/dy per
  // channel) if not null. pass_ms: interpolate.
  GpuTimes interpolate(const float* attr, std::int64_t channels, float* out = nullptr,
                       const std::int32_t* diff = nullptr, std::int64_t num_diff = 0, float* out_da = nullptr);

  // The last interpolate's serial (unique in the process, shared with
  // antialias_serial's): its attributes stay on the device for
  // interpolate_backward until another interpolate or a new G-buffer
  // replaces them (0 then, and before any interpolate).
  std::uint64_t interpolate_serial() const;

  // The adjoint of the last interpolate (raster::barycentric_interpolate_backward)
  // for grad_out (H x W x channels) and grad_da (H x W x 2 num_diff, or null:
  // the derivatives get no gradient), ACCUMULATED (+=) into grad_attr
  // (N x channels, summed in fixed point), grad_rast (H x W x 4: u, v) and
  // grad_db (H x W x 4), each may be null. The G-buffer's gradient is also
  // added (in float, per pixel) to the device's own, which rasterize_backward
  // reads: a chain interpolate -> rasterize adjoint needs no host round trip.
  // pass_ms: magnitudes and G-buffer gradient, sums, finish.
  GpuTimes interpolate_backward(const float* grad_out, const float* grad_da = nullptr, float* grad_attr = nullptr,
                                float* grad_rast = nullptr, float* grad_db = nullptr);

  // The adjoint of the last rasterize's G-buffer (raster::barycentric_gbuffer_backward,
  // for its coverage), ACCUMULATED (+=) into grad_clip (N x 4), for the
  // G-buffer gradient the interpolate adjoints left on the device since the
  // rasterize (or the last rasterize_backward), plus (in float) grad_rast
  // (H x W x 4: u, v, z/w; the id channel ignored) and grad_db (H x W x 4)
  // when given. The device's G-buffer gradient is consumed (zero after).
  // pass_ms: magnitudes, sums, finish.
  GpuTimes rasterize_backward(const float* grad_rast = nullptr, const float* grad_db = nullptr,
                              float* grad_clip = nullptr);

  // Drops the G-buffer gradient the interpolate adjoints left on the device
  // since the rasterize (or the last rasterize_backward), so that the next
  // rasterize_backward reads only the gradients it is given: for callers that
  // carry the G-buffer's gradient on the host (the ops' tape). No device work.
  void discard_gbuffer_gradient();

  // antialias_forward (raster/antialias.h) of image (H x W x channels) over
  // the last rasterize's G-buffer (tri_id, and z/w as the depth), clip
  // positions and triangles; out (H x W x
  // channels) if not null. The edge topology (build_edge_topology of the
  // triangles, no welding) is built on the host and uploaded on the first
  // call after a rasterize whose triangles differ from the last ones; else
  // the device's copy is reused. The pairs stay on the device for the
  // adjoint. image null: the last interpolate's output, which stays on the
  // device (its channel count must be `channels`). topology: the edge
  // topology to use instead (e.g. welded, raster::build_edge_topology with
  // positions; built for these triangles), uploaded unless the device holds
  // it already: the frame keeps the last one it uploaded, known by its
  // serial (an EdgeTopology is immutable; serial 0 is always uploaded), until
  // another topology replaces it (the caller's or the frame's own).
  // visibility: visibility_antialias_forward (raster/visibility_antialias.h)
  // instead, its pairs (edges and intersection crossings) and blends.
  // whole (may be null): the list the frame's triangles are a range of (its
  // rasterize's were rows whole->first.. of it; ValueError if not): the
  // pairs and blends are then those of the whole list's G-buffer (ids offset
  // by whole->first), as the CPU kernels give in range mode: the walks cross
  // into triangles outside the range. It needs the topology of the whole
  // list; the list is kept on the device and uploaded only when it differs
  // from the last one (counted in triangle_uploads). A whole that is the
  // frame's own list changes nothing. pass_ms: pairs, blend.
  GpuTimes antialias(const float* image, int channels, float* out = nullptr,
                     const raster::EdgeTopology* topology = nullptr, bool visibility = false,
                     const WholeTriangles* whole = nullptr);

  // The last antialias's serial (unique in the process): its pairs and image
  // stay on the device for antialias_backward until another antialias or a
  // new G-buffer (rasterize, load_gbuffer) replaces them (0 then, and before
  // any antialias). A caller that keeps it knows whether they are still there.
  std::uint64_t antialias_serial() const;

  // The adjoint of the last antialias (or visibility antialias) for grad_out (H x W x channels),
  // ACCUMULATED (+=) into grad_image (H x W x channels) and grad_clip (N x 4),
  // each may be null. pass_ms: image gradient and magnitudes, sums, finish.
  GpuTimes antialias_backward(const float* grad_out, float* grad_image, float* grad_clip);

  // The edge topologies antialias uploaded so far (the caller's and the
  // frame's own): how many, and their bytes (4 per edge).
  Uploads topology_uploads() const;
  // The triangle lists rasterize and load_gbuffer uploaded so far: a frame
  // keeps the last one on the device and uploads p.tris only when it differs
  // (compared with the frame's host copy), so a mesh whose triangles stay
  // the same goes up once per frame; likewise antialias's whole list (kept
  // apart from the frame's own).
  Uploads triangle_uploads() const;

 private:
  struct State;
  GpuTimes rasterize_into(const raster::RasterParams<float>& p, const GpuRasterOptions& options, bool coverage,
                          void* const (&outs)[3], double* key_depth);
  std::shared_ptr<Device> device_;
  std::unique_ptr<State> state_;
};

}  // namespace gr::vulkan
