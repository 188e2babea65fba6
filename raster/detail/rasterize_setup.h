// Internal to the raster kernels: per-vertex projection, per-triangle classification (frustum /
// area / facing / pixel bounding box) and the watertight edge setup shared by the
// rasterizer's tiles.
//
// Edge values are evaluated as e(p) = ((px - ax) dy - (py - ay) dx) + c from
// data that depend only on the edge's two vertices taken in a canonical order,
// with the sign flipped afterwards, so an edge shared by two triangles gives
// bit-identical |e| in both; e == 0 is settled by a top-left rule on (dy, -dx).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "raster/mesh_checks.h"  // the input checks, for this header's users

namespace gr::raster::detail {

// Per-vertex data in double: clip (x, y, z, w), screen (sx, sy), z_ndc, and
// whether the vertex is strictly in front of the near plane (w > 0, z >= -w).
struct Vertices {
  std::vector<double> clip;    // N x 4
  std::vector<double> screen;  // N x 3: sx, sy, z_ndc (valid when front[i])
  std::vector<std::uint8_t> front;
  // Frustum outcode: bit k set when the vertex is beyond plane k of w <= 0,
  // x > w, x < -w, y > w, y < -w, z < -w, z > w (so a triangle whose three
  // codes share a bit is outside, without reading the clip coordinates).
  std::vector<std::uint8_t> outcode;
};
// y_up (RasterSettings::y_up): row 0 is the bottom row; Vertices::clip then
// holds y negated (seen_y), so every later step works on the negated positions.
template <class T>
Vertices project_vertices(const T* clip, std::int64_t num_vertices, int width, int height, bool y_up = false);
// Same, into `out`, reusing its buffers (no allocation when they are big enough).
template <class T>
void project_vertices_into(const T* clip, std::int64_t num_vertices, int width, int height,
                           Vertices* out, bool y_up = false);

// The clip y a kernel computes with: negated when row 0 is the bottom row
// (y_up). Exact, so a y_up kernel gives the bits of the y_up = false kernel on
// a y-negated copy of clip; the y gradient it returns is negated back.
inline double seen_y(double y, bool y_up) { return y_up ? -y : y; }

// A free list of scratch objects reused across calls, so large per-call
// buffers are allocated (and page-faulted) once, not on every call. Each call
// takes its own object, so calls may run concurrently or nest (a thread that
// waits in a parallel_for may run another rasterize task). At most
// `max_free` objects wait on the list; more given back are freed.
template <class S>
class ScratchPool {
 public:
  explicit ScratchPool(std::size_t max_free = static_cast<std::size_t>(-1)) : max_free_(max_free) {}
  class Lease {
   public:
    Lease(ScratchPool* pool, std::unique_ptr<S> s) : pool_(pool), s_(std::move(s)) {}
    Lease(Lease&& other) noexcept : pool_(other.pool_), s_(std::move(other.s_)) {}
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() {
      if (s_) pool_->give(std::move(s_));
    }
    S& operator*() { return *s_; }
    S* operator->() { return s_.get(); }

   private:
    ScratchPool* pool_;
    std::unique_ptr<S> s_;
  };
  Lease take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) return Lease(this, std::make_unique<S>());
    std::unique_ptr<S> s = std::move(free_.back());
    free_.pop_back();
    return Lease(this, std::move(s));
  }

 private:
  void give(std::unique_ptr<S> s) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.size() < max_free_) free_.push_back(std::move(s));
  }
  const std::size_t max_free_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<S>> free_;
};

// A Vertices from a process-wide free list, given back to it when its last
// owner lets go: rasterize_forward's projection, which a G-buffer keeps for
// antialias_forward to reuse (raster/rasterize.h), costs no allocation once
// the list holds as many as are alive at once (it keeps at most
// kPooledVertices: a burst of G-buffers alive together gives its memory back).
constexpr std::size_t kPooledVertices = 32;
std::shared_ptr<Vertices> pooled_vertices();

// A triangle uses homogeneous (clipped) setup when a vertex is not in front.
inline bool needs_clipping(const Vertices& v, const std::int32_t* tri) {
  return !(v.front[tri[0]] && v.front[tri[1]] && v.front[tri[2]]);
}

// One edge, normalized so that e > 0 is the inside; tie: e == 0 counts inside.
// mu: lambda_k = e * mu (screen barycentric of the opposite vertex);
// mz: depth contribution e * mz.
struct Edge {
  double ax, ay, dx, dy, c;
  double mu, mz;
  bool tie;
  double row(double py) const { return (py - ay) * dx; }
  double eval(double px, double rowterm) const { return ((px - ax) * dy - rowterm) + c; }
  bool inside(double e) const { return (e > 0.0) | ((e == 0.0) & tie); }
};

struct TriSetup {
  Edge e[3];     // e[k] is opposite vertex k
  bool z_test;   // depth must be tested against [-1, 1] per pixel
};

// Outcome of classify_triangle.
enum class TriClass : std::uint8_t { Raster, Clipped, Outside, ZeroArea, Face, NoPixel };

// Inclusive pixel ranges of the triangle's pixel centres, clamped to the image.
struct PixelBox {
  std::int32_t x0, y0, x1, y1;
};

// Frustum rejection, area, culling and the pixel bounding box of triangle t.
// cull: 0 none, +1 drop back faces, -1 drop front faces.
TriClass classify_triangle(const Vertices& v, const std::int32_t* tri, int width, int height,
                           int cull, PixelBox* box);

// The weights half of setup_edges for a triangle with every vertex in front,
// of twice signed screen area a2: mu, mz and z_test (classify_lanes gives the
// edge values of small triangles itself).
void setup_screen_weights(const Vertices& v, const std::int32_t* tri, double a2, TriSetup* out);

// Edge functions of a triangle that classify_triangle accepted.
void setup_edges(const Vertices& v, const std::int32_t* tri, int width, int height,
                 TriSetup* out);

// Homogeneous screen vertex V = (W/2 (x + w), H/2 (w - y), w).
struct HVec {
  double x, y, w;
};
inline HVec homogeneous(const Vertices& v, std::int32_t i, int width, int height) {
  const double* c = &v.clip[4 * static_cast<std::size_t>(i)];
  return {0.5 * width * (c[0] + c[3]), 0.5 * height * (c[3] - c[1]), c[3]};
}
inline HVec cross(const HVec& a, const HVec& b) {
  return {a.y * b.w - a.w * b.y, a.w * b.x - a.x * b.w, a.x * b.y - a.y * b.x};
}
inline double dot(const HVec& a, const HVec& b) { return a.x * b.x + a.y * b.y + a.w * b.w; }

}  // namespace gr::raster::detail
