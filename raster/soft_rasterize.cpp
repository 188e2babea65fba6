// Soft rasterization and its adjoint (formulas in soft_rasterize.h).
//
// Triangles are binned once into 16 x 16 pixel tiles by their bounding box
// grown by the reach of the sigmoid, in triangle order. Each pixel scans its
// tile's list, keeps the max_faces nearest candidates and blends them. The
// adjoint re-evaluates each pixel the same way, computes its per-vertex
// contributions in parallel over a chunk of pixels and adds them in pixel
// order.
#include "raster/soft_rasterize.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/guarded_math.h"
#include "raster/project.h"

namespace gr::raster {
namespace {

using detail::finite_cast;

constexpr int kTile = 16;

// Screen-space triangles and their tile lists.
struct Bins {
  std::vector<double> screen;  // num_vertices x 3: x, y (pixels, y down), z_ndc
  int tiles_x = 0, tiles_y = 0;
  std::vector<std::vector<std::int32_t>> lists;  // per tile, ascending triangle index
};

template <class T>
Bins bin_triangles(const SoftRasterParams<T>& p) {
  Bins b;
  b.screen.resize(3 * static_cast<std::size_t>(p.num_vertices));
  std::vector<std::uint8_t> front(static_cast<std::size_t>(p.num_vertices));
  parallel_for(0, p.num_vertices, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const T* c = p.clip + 4 * i;
      const double w = c[3];
      front[i] = w > 0.0 && c[2] >= -w;
      b.screen[3 * i] = 0.5 * p.width * (1.0 + c[0] / w);
      b.screen[3 * i + 1] = 0.5 * p.height * (1.0 - c[1] / w);
      b.screen[3 * i + 2] = c[2] / w;
    }
  });
  b.tiles_x = (p.width + kTile - 1) / kTile;
  b.tiles_y = (p.height + kTile - 1) / kTile;
  b.lists.resize(static_cast<std::size_t>(b.tiles_x) * b.tiles_y);
  const double reach = std::sqrt(p.sigma * std::log((1.0 - kSoftCutoff) / kSoftCutoff));
  for (std::int64_t t = 0; t < p.num_tris; ++t) {
    const std::int32_t* v = p.tris + 3 * t;
    if (!front[v[0]] || !front[v[1]] || !front[v[2]]) continue;
    const double* P[3] = {&b.screen[3 * v[0]], &b.screen[3 * v[1]], &b.screen[3 * v[2]]};
    const double area2 = (P[1][0] - P[0][0]) * (P[2][1] - P[0][1]) - (P[1][1] - P[0][1]) * (P[2][0] - P[0][0]);
    if (!(std::abs(area2) > 1e-12)) continue;
    double x0 = P[0][0], x1 = x0, y0 = P[0][1], y1 = y0;
    for (int k = 1; k < 3; ++k) {
      x0 = std::min(x0, P[k][0]), x1 = std::max(x1, P[k][0]);
      y0 = std::min(y0, P[k][1]), y1 = std::max(y1, P[k][1]);
    }
    // Pixel centres col + 0.5 within [x0 - reach, x1 + reach].
    const double cx0 = std::ceil(x0 - reach - 0.5), cx1 = std::floor(x1 + reach - 0.5);
    const double cy0 = std::ceil(y0 - reach - 0.5), cy1 = std::floor(y1 + reach - 0.5);
    if (cx1 < 0 || cy1 < 0 || cx0 > p.width - 1 || cy0 > p.height - 1) continue;
    const int tx0 = static_cast<int>(std::max(0.0, cx0)) / kTile, tx1 = static_cast<int>(std::min(cx1, p.width - 1.0)) / kTile;
    const int ty0 = static_cast<int>(std::max(0.0, cy0)) / kTile, ty1 = static_cast<int>(std::min(cy1, p.height - 1.0)) / kTile;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) b.lists[static_cast<std::size_t>(ty) * b.tiles_x + tx].push_back(static_cast<std::int32_t>(t));
  }
  return b;
}

// One triangle at one pixel.
struct Candidate {
  std::int32_t tri = 0;
  bool inside = false;
  int edge = 0;           // nearest edge: opposite vertex `edge`, from vertex edge+1 to edge+2
  double t = 0;           // position of the nearest point on that edge
  bool t_free = false;    // 0 < t < 1 (t depends on the vertices)
  double qx = 0, qy = 0;  // the nearest point
  double d2 = 0, s = 0, D = 0, zs = 0, u = 0;
  double lambda[3] = {0, 0, 0};
};

// log(sigmoid(s)), stable for large |s|.
double log_sigmoid(double s) { return s > 0 ? -std::log1p(std::exp(-s)) : s - std::log1p(std::exp(s)); }

// Evaluates triangle `tri` at pixel centre (px, py); false if it does not reach it.
template <class T>
bool evaluate(const SoftRasterParams<T>& p, const Bins& b, std::int32_t tri, double px, double py, double max_d2,
              Candidate* c) {
  const std::int32_t* v = p.tris + 3 * static_cast<std::int64_t>(tri);
  const double* P[3] = {&b.screen[3 * v[0]], &b.screen[3 * v[1]], &b.screen[3 * v[2]]};
  // E_k = signed double area of (p, P_k+1, P_k+2); lambda_k = E_k / sum E.
  double E[3], area2 = 0;
  for (int k = 0; k < 3; ++k) {
    const double* a = P[(k + 1) % 3];
    const double* bb = P[(k + 2) % 3];
    E[k] = (a[0] - px) * (bb[1] - py) - (a[1] - py) * (bb[0] - px);
    area2 += E[k];
  }
  const bool inside = area2 > 0 ? (E[0] >= 0 && E[1] >= 0 && E[2] >= 0) : (E[0] <= 0 && E[1] <= 0 && E[2] <= 0);
  // Nearest edge segment.
  c->d2 = INFINITY;
  for (int k = 0; k < 3; ++k) {
    const double* a = P[(k + 1) % 3];
    const double* bb = P[(k + 2) % 3];
    const double ex = bb[0] - a[0], ey = bb[1] - a[1], m = ex * ex + ey * ey;
    const double raw = m > 0 ? ((px - a[0]) * ex + (py - a[1]) * ey) / m : 0.0;
    const double t = std::clamp(raw, 0.0, 1.0);
    const double qx = a[0] + t * ex, qy = a[1] + t * ey;
    const double d2 = (px - qx) * (px - qx) + (py - qy) * (py - qy);
    if (d2 < c->d2) {
      c->d2 = d2, c->edge = k, c->t = t, c->t_free = raw > 0.0 && raw < 1.0, c->qx = qx, c->qy = qy;
    }
  }
  if (!inside && c->d2 > max_d2) return false;
  c->tri = tri;
  c->inside = inside;
  c->s = (inside ? c->d2 : -c->d2) / p.sigma;
  c->D = 1.0 / (1.0 + std::exp(-c->s));
  if (inside) {
    for (int k = 0; k < 3; ++k) c->lambda[k] = E[k] / area2;
  } else {
    c->lambda[c->edge] = 0.0;
    c->lambda[(c->edge + 1) % 3] = 1.0 - c->t;
    c->lambda[(c->edge + 2) % 3] = c->t;
  }
  double z = 0;
  for (int k = 0; k < 3; ++k) z += c->lambda[k] * P[k][2];
  c->zs = 0.5 * (1.0 - z);
  c->u = log_sigmoid(c->s) + c->zs / p.gamma;
  // Screen positions far beyond the image (|x / w| up to 1e308) overflow the
  // edge functions' products: lambda, z and u then hold NaN, which the
  // softmax would spread over the pixel. Such a triangle does not reach the
  // pixel. (u = -Inf is exact: a weight of 0.)
  return !std::isnan(c->u) && std::isfinite(c->lambda[0]) && std::isfinite(c->lambda[1]) &&
         std::isfinite(c->lambda[2]) && std::isfinite(c->d2);
}

// The pixel's blend: its candidates (nearest first) and the weights.
struct Blend {
  std::vector<Candidate> faces;
  std::vector<double> w;
  double w_b = 1.0;
};

template <class T>
void blend_pixel(const SoftRasterParams<T>& p, const Bins& b, std::int64_t pixel, double max_d2, Blend* out) {
  const int col = static_cast<int>(pixel % p.width), row = static_cast<int>(pixel / p.width);
  const double px = col + 0.5, py = row + 0.5;
  out->faces.clear();
  Candidate c;
  for (std::int32_t tri : b.lists[static_cast<std::size_t>(row / kTile) * b.tiles_x + col / kTile]) {
    if (!evaluate(p, b, tri, px, py, max_d2, &c)) continue;
    // Keep the max_faces largest zs, ties to the lower index (tris come in ascending order).
    auto pos = std::find_if(out->faces.begin(), out->faces.end(), [&](const Candidate& f) { return c.zs > f.zs; });
    if (static_cast<int>(out->faces.size()) < p.max_faces) {
      out->faces.insert(pos, c);
    } else if (pos != out->faces.end()) {
      out->faces.insert(pos, c);
      out->faces.pop_back();
    }
  }
  const double u_b = p.eps / p.gamma;
  double m = u_b;
  for (const Candidate& f : out->faces) m = std::max(m, f.u);
  double sum = std::exp(u_b - m);
  out->w.resize(out->faces.size());
  for (std::size_t j = 0; j < out->faces.size(); ++j) sum += out->w[j] = std::exp(out->faces[j].u - m);
  for (double& w : out->w) w /= sum;
  out->w_b = std::exp(u_b - m) / sum;
}

double max_distance2(double sigma) { return sigma * std::log((1.0 - kSoftCutoff) / kSoftCutoff); }

// Per-pixel adjoint record of one candidate.
struct FaceGrad {
  std::int32_t tri;
  double screen[9];  // dL/d(x, y, z) of its three vertices
  double attr_w[3];  // dL/dA_k = attr_w[k] g
};

}  // namespace

template <class T>
void soft_rasterize_forward(const SoftRasterParams<T>& p, T* out) {
  const Bins b = bin_triangles(p);
  const double max_d2 = max_distance2(p.sigma);
  const std::int64_t C = p.channels;
  parallel_for(0, static_cast<std::int64_t>(p.width) * p.height, 1024, [&](std::int64_t lo, std::int64_t hi) {
    Blend blend;
    for (std::int64_t q = lo; q < hi; ++q) {
      blend_pixel(p, b, q, max_d2, &blend);
      T* o = out + q * C;
      for (std::int64_t ch = 0; ch < C; ++ch) {
        double v = blend.w_b * p.background[ch];
        for (std::size_t j = 0; j < blend.faces.size(); ++j) {
          const std::int32_t* tri = p.tris + 3 * static_cast<std::int64_t>(blend.faces[j].tri);
          double a = 0;
          for (int k = 0; k < 3; ++k) a += blend.faces[j].lambda[k] * p.attr[tri[k] * C + ch];
          v += blend.w[j] * a;
        }
        o[ch] = static_cast<T>(v);
      }
    }
  });
}

template <class T>
void soft_rasterize_backward(const SoftRasterParams<T>& p, const T* grad_out, const SoftRasterGrads<T>& grads) {
  const Bins b = bin_triangles(p);
  const double max_d2 = max_distance2(p.sigma);
  const std::int64_t C = p.channels, P = static_cast<std::int64_t>(p.width) * p.height;
  const std::int64_t N = p.num_vertices;
  std::vector<double> acc_screen(3 * static_cast<std::size_t>(N), 0.0), acc_attr;
  if (grads.attr) acc_attr.assign(static_cast<std::size_t>(N * C), 0.0);
  std::vector<double> acc_bg(static_cast<std::size_t>(C), 0.0);
  double acc_sigma = 0, acc_gamma = 0;

  constexpr std::int64_t kChunk = 4096;
  const std::int64_t len = std::min(kChunk, P);
  std::vector<std::vector<FaceGrad>> faces(static_cast<std::size_t>(len));
  std::vector<double> pix_sigma(len), pix_gamma(len), pix_wb(len);
  for (std::int64_t c0 = 0; c0 < P; c0 += kChunk) {
    const std::int64_t c1 = std::min(P, c0 + kChunk);
    parallel_for(c0, c1, 256, [&](std::int64_t lo, std::int64_t hi) {
      Blend blend;
      std::vector<double> gc;  // g . C_j
      for (std::int64_t q = lo; q < hi; ++q) {
        const std::int64_t i = q - c0;
        std::vector<FaceGrad>& fg = faces[i];
        fg.clear();
        pix_sigma[i] = pix_gamma[i] = pix_wb[i] = 0.0;
        const T* g = grad_out + q * C;
        bool any = false;
        for (std::int64_t ch = 0; ch < C && !any; ++ch) any = g[ch] != T(0);
        if (!any) continue;
        blend_pixel(p, b, q, max_d2, &blend);
        pix_wb[i] = blend.w_b;
        const std::size_t F = blend.faces.size();
        double g_b = 0;
        for (std::int64_t ch = 0; ch < C; ++ch) g_b += static_cast<double>(g[ch]) * p.background[ch];
        gc.assign(F, 0.0);
        double gbar = blend.w_b * g_b;
        for (std::size_t j = 0; j < F; ++j) {
          const std::int32_t* tri = p.tris + 3 * static_cast<std::int64_t>(blend.faces[j].tri);
          for (std::int64_t ch = 0; ch < C; ++ch) {
            double a = 0;
            for (int k = 0; k < 3; ++k) a += blend.faces[j].lambda[k] * p.attr[tri[k] * C + ch];
            gc[j] += static_cast<double>(g[ch]) * a;
          }
          gbar += blend.w[j] * gc[j];
        }
        const double u_b_grad = blend.w_b * (g_b - gbar);
        // (x / gamma) / gamma, never x / gamma^2: gamma^2 underflows from gamma < 1e-154 on.
        pix_gamma[i] = -u_b_grad * (p.eps / p.gamma) / p.gamma;
        const double px = q % p.width + 0.5, py = q / p.width + 0.5;
        for (std::size_t j = 0; j < F; ++j) {
          const Candidate& f = blend.faces[j];
          const std::int32_t* tri = p.tris + 3 * static_cast<std::int64_t>(f.tri);
          const double* P3[3] = {&b.screen[3 * tri[0]], &b.screen[3 * tri[1]], &b.screen[3 * tri[2]]};
          FaceGrad r{};
          r.tri = f.tri;
          const double gu = blend.w[j] * (gc[j] - gbar);
          const double gzs = gu / p.gamma;
          pix_gamma[i] -= gu * (f.zs / p.gamma) / p.gamma;
          const double gs = gu * (1.0 - f.D);
          // s = +-Inf (d^2 / sigma overflows) only where the sigmoid is flat: gs = 0 there.
          if (gs != 0.0) pix_sigma[i] -= gs * f.s / p.sigma;
          const double gd2 = (f.inside ? gs : -gs) / p.sigma;
          // dL/dlambda_k: from the colour (w_j g . A_k) and from zs = (1 - sum lambda z) / 2.
          double glam[3];
          for (int k = 0; k < 3; ++k) {
            double ga = 0;
            for (std::int64_t ch = 0; ch < C; ++ch) ga += static_cast<double>(g[ch]) * p.attr[tri[k] * C + ch];
            glam[k] = blend.w[j] * ga - 0.5 * gzs * P3[k][2];
            r.attr_w[k] = blend.w[j] * f.lambda[k];
            r.screen[3 * k + 2] = -0.5 * gzs * f.lambda[k];
          }
          // d^2 = |p - q|^2 on the nearest edge (a, b) = (edge + 1, edge + 2).
          const int ka = (f.edge + 1) % 3, kb = (f.edge + 2) % 3;
          const double rx = px - f.qx, ry = py - f.qy;
          r.screen[3 * ka] += -2.0 * rx * (1.0 - f.t) * gd2;
          r.screen[3 * ka + 1] += -2.0 * ry * (1.0 - f.t) * gd2;
          r.screen[3 * kb] += -2.0 * rx * f.t * gd2;
          r.screen[3 * kb + 1] += -2.0 * ry * f.t * gd2;
          if (f.inside) {
            // lambda_k = E_k / S: dL/dE_k = (glam_k - sum_j glam_j lambda_j) / S.
            double S = 0, dot = 0;
            double E[3];
            for (int k = 0; k < 3; ++k) {
              const double* a = P3[(k + 1) % 3];
              const double* bb = P3[(k + 2) % 3];
              E[k] = (a[0] - px) * (bb[1] - py) - (a[1] - py) * (bb[0] - px);
              S += E[k];
            }
            for (int k = 0; k < 3; ++k) dot += glam[k] * f.lambda[k];
            for (int k = 0; k < 3; ++k) {
              const double gE = (glam[k] - dot) / S;
              const int a = (k + 1) % 3, bb = (k + 2) % 3;
              // E = (ax - px)(by - py) - (ay - py)(bx - px).
              r.screen[3 * a] += gE * (P3[bb][1] - py);
              r.screen[3 * a + 1] -= gE * (P3[bb][0] - px);
              r.screen[3 * bb] -= gE * (P3[a][1] - py);
              r.screen[3 * bb + 1] += gE * (P3[a][0] - px);
            }
          } else if (f.t_free) {
            // lambda_a = 1 - t, lambda_b = t, t = (p - a).e / |e|^2, e = b - a.
            const double gt = glam[kb] - glam[ka];
            const double ex = P3[kb][0] - P3[ka][0], ey = P3[kb][1] - P3[ka][1], m = ex * ex + ey * ey;
            const double dx = px - P3[ka][0], dy = py - P3[ka][1];
            r.screen[3 * ka] += gt * (-(ex + dx) + 2.0 * f.t * ex) / m;
            r.screen[3 * ka + 1] += gt * (-(ey + dy) + 2.0 * f.t * ey) / m;
            r.screen[3 * kb] += gt * (dx - 2.0 * f.t * ex) / m;
            r.screen[3 * kb + 1] += gt * (dy - 2.0 * f.t * ey) / m;
          }
          fg.push_back(r);
        }
      }
    });
    // In pixel order.
    for (std::int64_t q = c0; q < c1; ++q) {
      const std::int64_t i = q - c0;
      const T* g = grad_out + q * C;
      acc_sigma += pix_sigma[i];
      acc_gamma += pix_gamma[i];
      for (std::int64_t ch = 0; ch < C; ++ch) acc_bg[ch] += pix_wb[i] * g[ch];
      for (const FaceGrad& r : faces[i]) {
        const std::int32_t* tri = p.tris + 3 * static_cast<std::int64_t>(r.tri);
        for (int k = 0; k < 3; ++k) {
          for (int d = 0; d < 3; ++d) acc_screen[3 * static_cast<std::size_t>(tri[k]) + d] += r.screen[3 * k + d];
          if (grads.attr)
            for (std::int64_t ch = 0; ch < C; ++ch) acc_attr[tri[k] * C + ch] += r.attr_w[k] * g[ch];
        }
      }
    }
  }
  if (grads.clip) screen_to_clip_backward(p.clip, N, p.width, p.height, acc_screen.data(), 3, grads.clip);
  if (grads.attr)
    for (std::int64_t i = 0; i < N * C; ++i) grads.attr[i] += finite_cast<T>(acc_attr[i]);
  if (grads.background)
    for (std::int64_t ch = 0; ch < C; ++ch) grads.background[ch] += finite_cast<T>(acc_bg[ch]);
  if (grads.sigma) *grads.sigma += acc_sigma;
  if (grads.gamma) *grads.gamma += acc_gamma;
}

#define GR_INSTANTIATE(T)                                                           \
  template void soft_rasterize_forward<T>(const SoftRasterParams<T>&, T*);           \
  template void soft_rasterize_backward<T>(const SoftRasterParams<T>&, const T*, \
                                           const SoftRasterGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
