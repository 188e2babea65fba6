#include "fused_blinn_phong.h"

#include <algorithm>
#include <cmath>

#include "autodiff/base/parallel.h"

namespace gr::bench {
namespace {

// Per-pixel math runs in the scene's own precision (float32 stays float32).
template <class T>
struct Vec3 {
  T x, y, z;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(T s) const { return {x * s, y * s, z * s}; }
  T dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
};

template <class T>
Vec3<T> load(const T* p) {
  return {p[0], p[1], p[2]};
}

// Dot products, lengths and the normalize adjoint's projection in Acc: T, or
// double for float32 at the tape's precision (ops/tensor/vector.h accumulates in double).
template <class Acc, class T>
Acc dot(const Vec3<T>& a, const Vec3<T>& b) {
  return Acc(a.x) * Acc(b.x) + Acc(a.y) * Acc(b.y) + Acc(a.z) * Acc(b.z);
}

// u = w / |w| with the inverse length in Acc.
template <class Acc, class T>
Vec3<T> scaled(const Vec3<T>& w, Acc inv_length) {
  return {T(Acc(w.x) * inv_length), T(Acc(w.y) * inv_length), T(Acc(w.z) * inv_length)};
}

// Adjoint of u = w / |w| (u already computed): dL/dw = (g - u (u . g)) / |w|.
template <class Acc, class T>
Vec3<T> normalize_adjoint(const Vec3<T>& u, Acc inv_length, const Vec3<T>& g) {
  const Acc ug = dot<Acc>(u, g);
  return {T((Acc(g.x) - Acc(u.x) * ug) * inv_length), T((Acc(g.y) - Acc(u.y) * ug) * inv_length),
          T((Acc(g.z) - Acc(u.z) * ug) * inv_length)};
}

// m^31 by squaring (std::pow costs more than the rest of the pixel).
template <class T>
T pow31(T m) {
  const T m2 = m * m, m4 = m2 * m2, m8 = m4 * m4, m16 = m8 * m8;
  return m16 * m8 * m4 * m2 * m;
}

// Per-block sums of the loss and of the light gradient (in double).
struct Partial {
  double loss = 0;
  Vec3<double> light{0, 0, 0};
  explicit Partial(int = 0) {}
  Partial& operator+=(const Partial& o) {
    loss += o.loss;
    light = light + o.light;
    return *this;
  }
};

// Pixels per lane block: the inputs are copied into one array per component
// (structure of arrays), so the per-pixel math below is a flat loop over lanes
// that the compiler vectorizes (8 float32 lanes with AVX2), square roots and
// divisions included; the outputs are interleaved back afterwards.
constexpr std::int64_t kLanes = 64;

template <class T>
struct LaneBlock {
  T p[3][kLanes], n[3][kLanes], a[3][kLanes], t[3][kLanes];  // inputs
  T gn[3][kLanes], ga[3][kLanes], gl[3][kLanes], loss[kLanes];  // per-pixel results
};

template <class T>
void deinterleave(const T* src, std::int64_t m, T (&dst)[3][kLanes]) {
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) dst[c][i] = src[3 * i + c];
}

template <class T>
void interleave(const T (&src)[3][kLanes], std::int64_t m, T* dst) {
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) dst[3 * i + c] = src[c][i];
}

// The forward and adjoint of lanes [0, m) of a block.
template <class T, class Acc>
void shade_lanes(LaneBlock<T>& b, std::int64_t m, const Vec3<T>& light, const Vec3<T>& cam, T scale) {
  using V = Vec3<T>;
  for (std::int64_t i = 0; i < m; ++i) {
    const V p{b.p[0][i], b.p[1][i], b.p[2][i]}, n{b.n[0][i], b.n[1][i], b.n[2][i]};
    const V a{b.a[0][i], b.a[1][i], b.a[2][i]}, t{b.t[0][i], b.t[1][i], b.t[2][i]};
    // Forward: l, v, h = normalize(l + v), the two lobes, the residual.
    const V to_light = light - p, to_cam = cam - p;
    const Acc il = 1 / std::sqrt(dot<Acc>(to_light, to_light)), iv = 1 / std::sqrt(dot<Acc>(to_cam, to_cam));
    const V l = scaled(to_light, il), v = scaled(to_cam, iv), half = l + v;
    const Acc ih = 1 / std::sqrt(dot<Acc>(half, half));
    const V h = scaled(half, ih);
    const T nl = T(dot<Acc>(n, l)), nh = T(dot<Acc>(n, h));
    // Selections between values computed either way, so the loop vectorizes.
    const T diffuse = std::max(nl, T(0)), lobe = std::max(nh, T(0));
    const T m31 = pow31(lobe);
    const V r = a * diffuse + V{1, 1, 1} * (T(0.5) * m31 * lobe) - t;
    b.loss[i] = r.dot(r);
    // Backward, in reverse order.
    const V g = r * scale;
    const V ga = g * diffuse;
    const T g_dot_a = T(dot<Acc>(g, a)), g_spec = T(0.5) * (g.x + g.y + g.z) * 32 * m31;
    const T g_nl = nl > 0 ? g_dot_a : T(0);
    const T g_nh = nh > 0 ? g_spec : T(0);
    const V gn = l * g_nl + h * g_nh;
    const V g_l = n * g_nl + normalize_adjoint(h, ih, n * g_nh);  // h = normalize(l + v)
    const V g_light = normalize_adjoint(l, il, g_l);              // l = normalize(light - p)
    b.ga[0][i] = ga.x, b.ga[1][i] = ga.y, b.ga[2][i] = ga.z;
    b.gn[0][i] = gn.x, b.gn[1][i] = gn.y, b.gn[2][i] = gn.z;
    b.gl[0][i] = g_light.x, b.gl[1][i] = g_light.y, b.gl[2][i] = g_light.z;
  }
}

}  // namespace

template <class T, class Acc>
void fused_blinn_phong(const ShadingScene& scene, FusedGradients<T>& out) {
  const std::int64_t pixels = scene.p.size(0);
  const T *P = scene.p.data<T>(), *N = scene.n.data<T>(), *A = scene.albedo.data<T>(), *target = scene.target.data<T>();
  const Vec3<T> light = load(scene.light.data<T>()), cam = load(scene.cam.data<T>());
  out.n.resize(pixels * 3);
  out.albedo.resize(pixels * 3);
  T *gn_out = out.n.data(), *ga_out = out.albedo.data();
  const T scale = T(2.0 / (3.0 * double(pixels)));  // d mean(r^2) / d r = 2 r / (3N)

  const Partial total = deterministic_sum<Partial>(pixels, 16384, [&](std::int64_t lo, std::int64_t hi) {
    Partial part;
    LaneBlock<T> b;
    for (std::int64_t i0 = lo; i0 < hi; i0 += kLanes) {
      const std::int64_t m = std::min(kLanes, hi - i0);
      deinterleave(P + 3 * i0, m, b.p);
      deinterleave(N + 3 * i0, m, b.n);
      deinterleave(A + 3 * i0, m, b.a);
      deinterleave(target + 3 * i0, m, b.t);
      shade_lanes<T, Acc>(b, m, light, cam, scale);
      interleave(b.ga, m, ga_out + 3 * i0);
      interleave(b.gn, m, gn_out + 3 * i0);
      // The sums in pixel order, in double.
      for (std::int64_t i = 0; i < m; ++i) {
        part.loss += double(b.loss[i]);
        part.light = part.light + Vec3<double>{b.gl[0][i], b.gl[1][i], b.gl[2][i]};
      }
    }
    return part;
  });
  out.loss = T(total.loss / (3.0 * double(pixels)));
  out.light = {T(total.light.x), T(total.light.y), T(total.light.z)};
}

template void fused_blinn_phong<float, float>(const ShadingScene&, FusedGradients<float>&);
template void fused_blinn_phong<float, double>(const ShadingScene&, FusedGradients<float>&);
template void fused_blinn_phong<double, double>(const ShadingScene&, FusedGradients<double>&);

}  // namespace gr::bench
