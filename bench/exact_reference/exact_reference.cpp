#include "bench/exact_reference/exact_reference.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"
#include "bench/exact_reference/polygon.h"
#include "bench/exact_reference/quadrature.h"

namespace gr::bench {
namespace {

using exact::Affine;
using exact::Point;
using exact::Polygon;
using Vec3 = std::array<double, 3>;
using Vec4 = std::array<double, 4>;

// Two depth planes closer than this (in z_ndc) over a whole pixel count as
// coplanar there: the tie goes to the smaller triangle index, as in the
// rasterizer's (depth, index) key. Genuinely crossing faces differ by far more.
constexpr double kCoplanarDepth = 1e-10;
constexpr int kTile = 8;  // binning tile, pixels

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// A triangle ready for the per-pixel work. With homogeneous screen vertices
// V_k = (W/2 (x + w), H/2 (w - y), w) and s = (x, y, 1), F_k(s) = s . cross_k
// (cross_k = V_{k+1} x V_{k+2}) gives the clip-space barycentrics
// b_k = F_k / sum F, so attribute = sum A_k F_k / sum F and
// z_ndc = sum z_k F_k / D (D = V_0 . cross_0), affine in screen space.
struct Prepared {
  std::int64_t index = 0;
  std::array<Vec3, 3> cross{};
  std::array<std::int64_t, 3> vertex{};
  Affine depth{};
  Polygon shape;  // the near/far-clipped triangle in screen space
  std::vector<Affine> edges;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // bounding box of shape
};

// Sutherland-Hodgman in clip space against f(v) >= 0 for a linear f.
template <class F>
std::vector<Vec4> clip_homogeneous(const std::vector<Vec4>& in, F f) {
  std::vector<Vec4> out;
  for (std::size_t i = 0, n = in.size(); i < n; ++i) {
    const Vec4& p = in[(i + n - 1) % n];
    const Vec4& q = in[i];
    const double fp = f(p), fq = f(q);
    if ((fp >= 0) != (fq >= 0)) {
      const double t = fp / (fp - fq);
      Vec4 r;
      for (int k = 0; k < 4; ++k) r[k] = p[k] + t * (q[k] - p[k]);
      out.push_back(r);
    }
    if (fq >= 0) out.push_back(q);
  }
  return out;
}

// Returns false for triangles that cannot be seen (zero area, culled, clipped
// away, off screen).
bool prepare(const double* clip, const std::int32_t* tri, std::int64_t t, int width, int height, raster::Cull cull,
             Prepared& p) {
  std::array<Vec3, 3> v;
  std::vector<Vec4> poly;
  double wmax = 0;
  for (int k = 0; k < 3; ++k) {
    const double* c = clip + 4 * static_cast<std::int64_t>(tri[3 * t + k]);
    p.vertex[k] = tri[3 * t + k];
    v[k] = {0.5 * width * (c[0] + c[3]), 0.5 * height * (c[3] - c[1]), c[3]};
    poly.push_back({c[0], c[1], c[2], c[3]});
    wmax = std::max(wmax, std::abs(c[3]));
  }
  for (int k = 0; k < 3; ++k) p.cross[k] = cross(v[(k + 1) % 3], v[(k + 2) % 3]);
  const double d = dot(v[0], p.cross[0]);
  if (d == 0) return false;
  const bool front = d < 0;  // = 2A > 0 in screen space when every w > 0
  if ((cull == raster::Cull::Back && !front) || (cull == raster::Cull::Front && front)) return false;
  Vec3 z{};
  bool finite = std::isfinite(d);
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) {
      z[i] += poly[k][2] * p.cross[k][i] / d;
      finite = finite && std::isfinite(p.cross[k][i]) && std::isfinite(z[i]);
    }
  if (!finite)
    throw ValueError("exact_box_filtered: triangle " + std::to_string(t) +
                     " has clip coordinates too large for double arithmetic (its set-up overflows)");
  p.depth = {z[0], z[1], z[2]};

  // The visible volume: -w <= z <= w (near and far planes, as the rasterizer
  // clips per pixel), and w above a tiny fraction of the largest |w|.
  poly = clip_homogeneous(poly, [](const Vec4& q) { return q[3] + q[2]; });
  poly = clip_homogeneous(poly, [](const Vec4& q) { return q[3] - q[2]; });
  poly = clip_homogeneous(poly, [wmax](const Vec4& q) { return q[3] - 1e-12 * wmax; });
  if (poly.size() < 3) return false;
  p.shape.clear();
  for (const Vec4& q : poly)
    p.shape.push_back({0.5 * width * (1 + q[0] / q[3]), 0.5 * height * (1 - q[1] / q[3])});
  const double area = exact::signed_area(p.shape);
  if (!(std::abs(area) > 0)) return false;
  if (area < 0) std::reverse(p.shape.begin(), p.shape.end());
  p.edges = exact::inward_edges(p.shape);
  p.x0 = p.x1 = p.shape[0].x;
  p.y0 = p.y1 = p.shape[0].y;
  for (const Point& q : p.shape) {
    p.x0 = std::min(p.x0, q.x), p.x1 = std::max(p.x1, q.x);
    p.y0 = std::min(p.y0, q.y), p.y1 = std::max(p.y1, q.y);
  }
  p.index = t;
  return p.x1 > 0 && p.x0 < width && p.y1 > 0 && p.y0 < height;
}

void validate(const Tensor& clip, const Tensor& triangles, const Tensor& attributes, int width, int height,
              const Tensor& background, const ExactReferenceOptions& options) {
  const std::string op = "exact_box_filtered: ";
  if (!clip.defined() || clip.rank() != 2 || clip.size(1) != 4)
    throw ShapeError(op + "clip must be [N, 4]");
  if (clip.dtype() != DType::Float64) throw DTypeError(op + "clip must be float64");
  if (!triangles.defined() || triangles.rank() != 2 || triangles.size(1) != 3)
    throw ShapeError(op + "triangles must be [M, 3]");
  if (triangles.dtype() != DType::Int32) throw DTypeError(op + "triangles must be int32");
  if (!attributes.defined() || attributes.rank() != 2 || attributes.size(0) != clip.size(0) || attributes.size(1) < 1)
    throw ShapeError(op + "attributes must be [N, C] with N = clip's " + std::to_string(clip.size(0)) + " and C >= 1");
  if (attributes.dtype() != DType::Float64) throw DTypeError(op + "attributes must be float64");
  if (!background.defined() || background.rank() != 1 || background.size(0) != attributes.size(1))
    throw ShapeError(op + "background must be [C] with C = " + std::to_string(attributes.size(1)));
  if (background.dtype() != DType::Float64) throw DTypeError(op + "background must be float64");
  if (width < 1 || height < 1)
    throw ValueError(op + "image size " + std::to_string(width) + "x" + std::to_string(height) + " must be at least 1x1");
  if (options.quadrature_order < 1 || options.quadrature_order > 32)
    throw ValueError(op + "quadrature_order " + std::to_string(options.quadrature_order) + " must be in 1..32");
  if (!options.only_pixels.empty() && options.only_pixels.size() != std::size_t(width) * std::size_t(height))
    throw ShapeError(op + "only_pixels has " + std::to_string(options.only_pixels.size()) + " flags, the image " +
                     std::to_string(width) + "x" + std::to_string(height) + " pixels");
  const std::int64_t n = clip.size(0);
  const std::int32_t* tri = triangles.data<std::int32_t>();
  for (std::int64_t i = 0; i < triangles.numel(); ++i)
    if (tri[i] < 0 || tri[i] >= n)
      throw IndexError(op + "triangle " + std::to_string(i / 3) + " has vertex index " + std::to_string(tri[i]) +
                       " outside [0, " + std::to_string(n) + ")");
  const auto check_finite = [&](const Tensor& t, const std::string& name, std::int64_t row) {
    const double* d = t.data<double>();
    for (std::int64_t i = 0; i < t.numel(); ++i)
      if (!std::isfinite(d[i]))
        throw ValueError(op + name + " row " + std::to_string(i / row) + " is not finite (" + std::to_string(d[i]) + ")");
  };
  check_finite(clip, "clip", 4);
  check_finite(attributes, "attributes", attributes.size(1));
  check_finite(background, "background", background.numel());
}

// Everything one pixel needs, reused across the pixels of a tile.
struct PixelScratch {
  std::vector<const Prepared*> candidates;
  std::vector<Polygon> pieces, next;
  std::vector<Affine> occluder;
  Polygon square, piece;
  std::vector<double> value;
};

// Adds the visible part of `tri` inside s.square to coverage and its
// attribute integral to sum.
void integrate_visible(const Prepared& tri, const double* attributes, std::int64_t channels,
                       const std::vector<exact::TriangleNode>& rule, PixelScratch& s, double& coverage, double* sum) {
  const Point corners[4] = {s.square[0], s.square[1], s.square[2], s.square[3]};
  s.pieces.assign(1, s.square);
  for (const Affine& e : tri.edges) {
    exact::clip(s.pieces[0], e, s.piece);
    s.pieces[0].swap(s.piece);
    if (s.pieces[0].empty()) return;
  }
  for (const Prepared* other : s.candidates) {
    if (other == &tri) continue;
    const Affine g = other->depth - tri.depth;  // < 0 where `other` is nearer
    double gmin = g(corners[0]), gmax = gmin;
    for (const Point& c : corners) gmin = std::min(gmin, g(c)), gmax = std::max(gmax, g(c));
    s.occluder = other->edges;
    if (std::max(-gmin, gmax) <= kCoplanarDepth) {
      if (other->index > tri.index) continue;  // coplanar here: the smaller index wins
    } else {
      if (gmin >= 0) continue;  // behind (or touching) everywhere in the pixel
      if (gmax > 0) s.occluder.push_back(-g);
    }
    s.next.clear();
    for (const Polygon& r : s.pieces) exact::subtract(r, s.occluder, s.next);
    s.pieces.swap(s.next);
    if (s.pieces.empty()) return;
  }
  for (const Polygon& r : s.pieces) {
    for (std::size_t k = 1; k + 1 < r.size(); ++k) {  // fan triangles
      const Point a = r[0], b = r[k], c = r[k + 1];
      const double area = 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
      coverage += area;
      std::fill(s.value.begin(), s.value.end(), 0.0);
      for (const exact::TriangleNode& node : rule) {
        const Vec3 q{a.x + node.s * (b.x - a.x) + node.t * (c.x - a.x), a.y + node.s * (b.y - a.y) + node.t * (c.y - a.y),
                     1.0};
        double f[3], total = 0;
        for (int m = 0; m < 3; ++m) total += f[m] = dot(q, tri.cross[m]);
        for (int m = 0; m < 3; ++m) {
          const double wk = node.weight * f[m] / total;  // perspective-correct barycentric x weight
          const double* attr = attributes + tri.vertex[m] * channels;
          for (std::int64_t ch = 0; ch < channels; ++ch) s.value[ch] += wk * attr[ch];
        }
      }
      for (std::int64_t ch = 0; ch < channels; ++ch) sum[ch] += area * s.value[ch];
    }
  }
}

}  // namespace

ExactImage exact_box_filtered(const Tensor& clip, const Tensor& triangles, const Tensor& attributes, int width,
                              int height, const Tensor& background, const ExactReferenceOptions& options) {
  validate(clip, triangles, attributes, width, height, background, options);
  const std::int64_t channels = attributes.size(1), pixels = static_cast<std::int64_t>(width) * height;
  const std::int64_t num_triangles = triangles.size(0);
  // The outputs plus a rough bound on the set-up and bins per triangle.
  check_memory_request(static_cast<std::size_t>(pixels * (channels + 1) * 8 + num_triangles * 512),
                       "exact reference " + std::to_string(width) + "x" + std::to_string(height));

  std::vector<Prepared> prepared;
  {
    const double* c = clip.data<double>();
    const std::int32_t* tri = triangles.data<std::int32_t>();
    Prepared p;
    for (std::int64_t t = 0; t < num_triangles; ++t)
      if (prepare(c, tri, t, width, height, options.cull, p)) prepared.push_back(p);
  }
  // Bin by bounding box into tiles (each list in ascending triangle order).
  const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  std::vector<std::vector<const Prepared*>> bins(static_cast<std::size_t>(tiles_x) * tiles_y);
  for (const Prepared& p : prepared) {
    // The box is clamped to the image before the integer casts (a clipped
    // triangle can project far outside it).
    const int tx0 = static_cast<int>(std::max(0.0, p.x0)) / kTile;
    const int tx1 = static_cast<int>(std::min<double>(p.x1, width - 1)) / kTile;
    const int ty0 = static_cast<int>(std::max(0.0, p.y0)) / kTile;
    const int ty1 = static_cast<int>(std::min<double>(p.y1, height - 1)) / kTile;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) bins[static_cast<std::size_t>(ty) * tiles_x + tx].push_back(&p);
  }

  ExactImage out{Tensor::zeros({height, width, channels}, DType::Float64), Tensor::zeros({height, width}, DType::Float64)};
  double* image = out.image.data<double>();
  double* coverage = out.coverage.data<double>();
  const double* attr = attributes.data<double>();
  const double* bg = background.data<double>();
  const std::vector<exact::TriangleNode> rule = exact::triangle_rule(options.quadrature_order);
  parallel_for(0, static_cast<std::int64_t>(bins.size()), 1, [&](std::int64_t b0, std::int64_t b1) {
    PixelScratch s;
    s.value.resize(channels);
    for (std::int64_t b = b0; b < b1; ++b) {
      const int tx = static_cast<int>(b % tiles_x), ty = static_cast<int>(b / tiles_x);
      for (int py = ty * kTile; py < std::min(height, ty * kTile + kTile); ++py)
        for (int px = tx * kTile; px < std::min(width, tx * kTile + kTile); ++px) {
          double* sum = image + (static_cast<std::int64_t>(py) * width + px) * channels;
          if (!options.only_pixels.empty() && !options.only_pixels[static_cast<std::size_t>(py) * width + px]) {
            std::copy(bg, bg + channels, sum);
            continue;
          }
          s.square = {{double(px), double(py)}, {px + 1.0, double(py)}, {px + 1.0, py + 1.0}, {double(px), py + 1.0}};
          s.candidates.clear();
          for (const Prepared* p : bins[b])
            if (p->x1 > px && p->x0 < px + 1 && p->y1 > py && p->y0 < py + 1) s.candidates.push_back(p);
          double& cov = coverage[static_cast<std::int64_t>(py) * width + px];
          for (const Prepared* p : s.candidates) integrate_visible(*p, attr, channels, rule, s, cov, sum);
          for (std::int64_t ch = 0; ch < channels; ++ch) sum[ch] += (1 - cov) * bg[ch];
        }
    }
  });
  return out;
}

}  // namespace gr::bench
