#include "fused_blinn_phong.h"

#include <cmath>

#include "autodiff/parallel.h"

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

template <class T>
void store(const Vec3<T>& v, T* p) {
  p[0] = v.x;
  p[1] = v.y;
  p[2] = v.z;
}

// Adjoint of u = w / |w| (u already computed): dL/dw = (g - u (u . g)) / |w|.
template <class T>
Vec3<T> normalize_adjoint(const Vec3<T>& u, T inv_length, const Vec3<T>& g) {
  return (g - u * u.dot(g)) * inv_length;
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

}  // namespace

template <class T>
void fused_blinn_phong(const ShadingScene& scene, FusedGradients<T>& out) {
  const std::int64_t pixels = scene.p.size(0);
  const T *P = scene.p.data<T>(), *N = scene.n.data<T>(), *A = scene.albedo.data<T>(), *target = scene.target.data<T>();
  using V = Vec3<T>;
  const V light = load(scene.light.data<T>()), cam = load(scene.cam.data<T>());
  out.n.resize(pixels * 3);
  out.albedo.resize(pixels * 3);
  T *gn_out = out.n.data(), *ga_out = out.albedo.data();
  const T scale = T(2.0 / (3.0 * double(pixels)));  // d mean(r^2) / d r = 2 r / (3N)

  const Partial total = deterministic_sum<Partial>(pixels, 16384, [&](std::int64_t lo, std::int64_t hi) {
    Partial part;
    for (std::int64_t i = lo; i < hi; ++i) {
      const V p = load(P + 3 * i), n = load(N + 3 * i), a = load(A + 3 * i), t = load(target + 3 * i);
      // Forward: l, v, h = normalize(l + v), the two lobes, the residual.
      const V to_light = light - p, to_cam = cam - p;
      const T il = 1 / std::sqrt(to_light.dot(to_light)), iv = 1 / std::sqrt(to_cam.dot(to_cam));
      const V l = to_light * il, v = to_cam * iv, half = l + v;
      const T ih = 1 / std::sqrt(half.dot(half));
      const V h = half * ih;
      const T nl = n.dot(l), nh = n.dot(h);
      const T diffuse = nl > 0 ? nl : 0, m = nh > 0 ? nh : 0;
      const T m31 = pow31(m);
      const V r = a * diffuse + V{1, 1, 1} * (T(0.5) * m31 * m) - t;
      part.loss += double(r.dot(r));
      // Backward, in reverse order.
      const V g = r * scale;
      store(g * diffuse, ga_out + 3 * i);
      const T g_nl = nl > 0 ? g.dot(a) : 0;
      const T g_nh = nh > 0 ? T(0.5) * (g.x + g.y + g.z) * 32 * m31 : 0;
      store(l * g_nl + h * g_nh, gn_out + 3 * i);
      const V g_l = n * g_nl + normalize_adjoint(h, ih, n * g_nh);  // h = normalize(l + v)
      const V g_light = normalize_adjoint(l, il, g_l);              // l = normalize(light - p)
      part.light = part.light + Vec3<double>{g_light.x, g_light.y, g_light.z};
    }
    return part;
  });
  out.loss = T(total.loss / (3.0 * double(pixels)));
  out.light = {T(total.light.x), T(total.light.y), T(total.light.z)};
}

template void fused_blinn_phong<float>(const ShadingScene&, FusedGradients<float>&);
template void fused_blinn_phong<double>(const ShadingScene&, FusedGradients<double>&);

}  // namespace gr::bench
