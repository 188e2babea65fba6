// Tests of interpolate's adjoint where its parallel scatter can go wrong:
// many pixels per vertex, triangles spanning the split points of the item
// ranges, vertices shared by many triangles, triangles with no pixels and
// triangles clipped by the near plane. The sums must be bit-identical for 1,
// 2 and 8 threads, equal in image and fragment form and for any triangle
// order, and match finite differences in float64. The forward's and the
// adjoint's vectorized loops (rows of 3) must give their per-item loops' values.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/interpolate.h"
#include "raster/clip_scene.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

template <class T>
std::vector<T> cast_to(const std::vector<double>& v) {
  return std::vector<T>(v.begin(), v.end());
}

// Image-form params over the scene's data, converted to T.
template <class T>
struct Typed {
  std::vector<T> attr, clip, uv;
  explicit Typed(const ClipScene& s) : attr(cast_to<T>(s.attr)), clip(cast_to<T>(s.clip)), uv(cast_to<T>(s.uv)) {}
  InterpolateParams<T> params(const ClipScene& s) const {
    InterpolateParams<T> p;
    p.attr = attr.data();
    p.num_vertices = s.N;
    p.channels = s.C;
    p.clip = clip.data();
    p.tris = s.tris.data();
    p.num_tris = s.M;
    p.tri_id = s.id.data();
    p.uv = uv.data();
    p.width = s.W;
    p.height = s.H;
    return p;
  }
};

// The scene's covered pixels as a fragment list (pixel, triangle id, uv).
template <class T>
struct FragmentList {
  std::vector<std::int32_t> pixel, id;
  std::vector<T> uv;
  FragmentList(const ClipScene& s, const std::vector<T>& image_uv) {
    for (std::int64_t q = 0; q < static_cast<std::int64_t>(s.id.size()); ++q) {
      if (s.id[q] == 0) continue;
      pixel.push_back(static_cast<std::int32_t>(q));
      id.push_back(s.id[q]);
      uv.insert(uv.end(), {image_uv[2 * q], image_uv[2 * q + 1]});
    }
  }
  // p in fragment form over this list.
  void use_in(InterpolateParams<T>* p) const {
    p->pixel_index = pixel.data();
    p->count = static_cast<std::int64_t>(pixel.size());
    p->tri_id = id.data();
    p->uv = uv.data();
  }
};

// dL/dattr, dL/dclip and dL/duv (image order), concatenated; in fragment
// form when `fragments`, with uv gradients scattered back to their pixels.
template <class T>
std::vector<T> adjoint(const ClipScene& s, const std::vector<T>& g, int threads, bool fragments) {
  const Typed<T> in(s);
  InterpolateParams<T> p = in.params(s);
  const FragmentList<T> list(s, in.uv);
  std::vector<T> frag_g;
  if (fragments) {
    list.use_in(&p);
    for (std::int32_t q : list.pixel) frag_g.insert(frag_g.end(), g.begin() + q * s.C, g.begin() + (q + 1) * s.C);
  }
  std::vector<T> ga(in.attr.size(), T(0)), gc(in.clip.size(), T(0)), gu(fragments ? list.uv.size() : in.uv.size());
  set_num_threads(threads);
  interpolate_backward(p, fragments ? frag_g.data() : g.data(), {ga.data(), gc.data(), gu.data()});
  set_num_threads(0);
  std::vector<T> uv_image(in.uv.size(), T(0));
  if (fragments)
    for (std::size_t f = 0; f < list.pixel.size(); ++f) {
      uv_image[2 * list.pixel[f]] = gu[2 * f];
      uv_image[2 * list.pixel[f] + 1] = gu[2 * f + 1];
    }
  else
    uv_image = gu;
  ga.insert(ga.end(), gc.begin(), gc.end());
  ga.insert(ga.end(), uv_image.begin(), uv_image.end());
  return ga;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

template <class T>
void check_thread_independence() {
  // 384 x 256 = 98304 pixels: six item ranges of 16384 at 8 threads; every
  // grid vertex is shared by six triangles of ~60 pixels spanning several rows.
  const ClipScene s = grid_and_fan(384, 256, 24, 16, 48);
  std::int64_t covered = 0;
  for (std::int32_t i : s.id) covered += i != 0;
  REQUIRE(covered > 40000);
  const std::vector<T> g = cast_to<T>(random_vector(s.id.size() * s.C, -1, 1, 3));
  const std::vector<T> one = adjoint<T>(s, g, 1, false);
  // Some clipped triangle's vertex got an x gradient (the homogeneous path ran).
  bool clipped_path = false;
  for (int v = 0; v < s.N; ++v)
    if (s.clip[4 * v + 3] < 0 && one[s.N * s.C + 4 * v] != T(0)) clipped_path = true;
  CHECK(clipped_path);
  for (int threads : {2, 8, 1}) {
    INFO(threads << " threads");
    CHECK(same_bits(one, adjoint<T>(s, g, threads, false)));
    CHECK(same_bits(one, adjoint<T>(s, g, threads, true)));
  }
  // The triangles in reverse order (the G-buffer renumbered to match): same bits.
  ClipScene r = s;
  for (int t = 0; t < s.M; ++t)
    for (int k = 0; k < 3; ++k) r.tris[3 * (s.M - 1 - t) + k] = s.tris[3 * t + k];
  for (std::int32_t& i : r.id)
    if (i) i = s.M + 1 - i;
  CHECK(same_bits(one, adjoint<T>(r, g, 2, false)));
}

// The scene with every vertex behind the camera mirrored through the eye
// (clip -> -clip: same projection, now in front), so no triangle is clipped.
ClipScene in_front(ClipScene s) {
  for (std::size_t v = 0; v < s.clip.size(); v += 4)
    if (s.clip[v + 3] <= 0)
      for (int d = 0; d < 4; ++d) s.clip[v + d] = -s.clip[v + d];
  s.rasterize();
  return s;
}

// The same scene with two more attribute channels.
ClipScene with_two_more_channels(const ClipScene& s) {
  ClipScene wide = s;
  wide.C = 5;
  const std::vector<double> extra = random_vector(2 * static_cast<std::size_t>(s.N), -1, 1, 10);
  wide.attr.clear();
  for (int v = 0; v < s.N; ++v)
    wide.attr.insert(wide.attr.end(),
                     {s.attr[3 * v], s.attr[3 * v + 1], s.attr[3 * v + 2], extra[2 * v], extra[2 * v + 1]});
  return wide;
}

// Image-form forward (fragment form when `fragments`, scattered back to the image).
template <class T>
std::vector<T> forward(const ClipScene& s, bool fragments, const T* background) {
  const Typed<T> in(s);
  InterpolateParams<T> p = in.params(s);
  p.background = background;
  const FragmentList<T> list(s, in.uv);
  if (fragments) list.use_in(&p);
  std::vector<T> out(static_cast<std::size_t>(p.items() * s.C));
  interpolate_forward(p, out.data());
  if (!fragments) return out;
  std::vector<T> image(s.id.size() * s.C, T(-7));
  for (std::size_t f = 0; f < list.pixel.size(); ++f)
    for (int c = 0; c < s.C; ++c) image[list.pixel[f] * s.C + c] = out[f * s.C + c];
  return image;
}

// Attribute rows of 3 take the forward's vectorized loop (every vertex in
// front), rows of 5 its per-item loop: the first three channels must be equal.
template <class T>
void check_vectorized_forward(bool fragments) {
  const ClipScene s = in_front(grid_and_fan(97, 61, 5, 4, 24));
  const ClipScene wide = with_two_more_channels(s);
  const T background[5] = {T(0.25), T(-0.5), T(2), T(3), T(4)};
  for (const T* bg : {static_cast<const T*>(nullptr), background}) {
    const std::vector<T> narrow = forward<T>(s, fragments, bg), broad = forward<T>(wide, fragments, bg);
    int unequal = 0, covered = 0, background_ok = 0;
    for (std::size_t q = 0; q < s.id.size(); ++q) {
      for (int c = 0; c < 3; ++c) unequal += narrow[3 * q + c] != broad[5 * q + c];
      covered += s.id[q] != 0;
      background_ok += s.id[q] == 0 && narrow[3 * q + 1] == (fragments ? T(-7) : bg ? bg[1] : T(0));
    }
    CHECK(unequal == 0);
    CHECK(covered > 2000);
    CHECK(background_ok == static_cast<int>(s.id.size()) - covered);
  }
}

// Attribute rows of 3 take the adjoint's vectorized walk, rows of 5 its
// per-item walk. Two extra channels with a zero incoming gradient add only
// zeros to each item's terms, so the first three channels' gradients, and
// those to clip and uv, must be equal (== also takes -0 for +0).
template <class T>
void check_vectorized_walk(bool fragments) {
  // Odd sizes: triangles whose item counts are not multiples of the batch.
  const ClipScene s = grid_and_fan(97, 61, 5, 4, 24);
  std::vector<double> g = random_vector(s.id.size() * s.C, -1, 1, 9);
  // Every third pixel gets a zero gradient (the skip rule).
  for (std::size_t q = 0; q < s.id.size(); q += 3)
    for (int c = 0; c < s.C; ++c) g[q * s.C + c] = 0.0;
  const ClipScene wide = with_two_more_channels(s);
  std::vector<double> g_wide;
  for (std::size_t q = 0; q < s.id.size(); ++q)
    g_wide.insert(g_wide.end(), {g[3 * q], g[3 * q + 1], g[3 * q + 2], 0.0, 0.0});
  const std::vector<T> narrow_grad = adjoint<T>(s, cast_to<T>(g), 2, fragments);
  const std::vector<T> wide_grad = adjoint<T>(wide, cast_to<T>(g_wide), 2, fragments);
  const std::size_t NA = s.attr.size(), WA = wide.attr.size(), rest = narrow_grad.size() - NA;
  REQUIRE(wide_grad.size() == WA + rest);
  int unequal = 0, nonzero = 0;
  for (int v = 0; v < s.N; ++v)
    for (int c = 0; c < 3; ++c) {
      unequal += narrow_grad[3 * v + c] != wide_grad[5 * v + c];
      nonzero += narrow_grad[3 * v + c] != T(0);
    }
  for (std::size_t i = 0; i < rest; ++i) {
    unequal += narrow_grad[NA + i] != wide_grad[WA + i];
    nonzero += narrow_grad[NA + i] != T(0);
  }
  CHECK(unequal == 0);
  CHECK(nonzero > 5000);
}

}  // namespace

TEST_CASE("interpolate: the vectorized loops over rows of 3 give the per-item loops' values and gradients",
          "[raster][interpolate][determinism]") {
  for (bool fragments : {false, true}) {
    INFO((fragments ? "fragment form" : "image form"));
    check_vectorized_forward<float>(fragments);
    check_vectorized_forward<double>(fragments);
    check_vectorized_walk<float>(fragments);
    check_vectorized_walk<double>(fragments);
  }
}

TEST_CASE("interpolate adjoint: bit-identical for 1, 2 and 8 threads, in fragment form and for reversed triangles",
          "[raster][interpolate][determinism]") {
  SECTION("float32") { check_thread_independence<float>(); }
  SECTION("float64") { check_thread_independence<double>(); }
}

TEST_CASE("interpolate adjoint: matches finite differences with a 24-triangle fan, empty and clipped triangles",
          "[raster][interpolate][gradient]") {
  ClipScene s = grid_and_fan(40, 32, 3, 4, 24);
  // Triangles with no pixel: degenerate (a repeated vertex), off screen (x > w)
  // and smaller than the pixel spacing between centres.
  const std::int32_t hub = 20;  // first fan vertex (the grid has 4 x 5 vertices)
  const std::int32_t extra = static_cast<std::int32_t>(s.clip.size() / 4);
  s.clip.insert(s.clip.end(), {3.0, 0.0, 0.0, 1.0, 3.5, 0.5, 0.0, 1.0, 3.2, -0.4, 0.0, 1.0,  // off screen
                               0.495, 0.37, -0.9, 1.0, 0.505, 0.37, -0.9, 1.0, 0.5, 0.38, -0.9, 1.0});  // tiny
  s.tris.insert(s.tris.end(), {hub, hub + 1, hub + 1, extra, extra + 1, extra + 2, extra + 3, extra + 4, extra + 5});
  s.rasterize();
  const std::int64_t per_fan = 24;
  REQUIRE(s.N == extra + 6);
  // The hub is covered on all its triangles; some grid vertex is behind the camera.
  std::vector<int> pixels_of(s.M, 0);
  for (std::int32_t i : s.id)
    if (i) ++pixels_of[i - 1];
  int fan_covered = 0;
  for (int t = s.M - 3 - per_fan; t < s.M - 3; ++t) fan_covered += pixels_of[t] > 0;
  CHECK(fan_covered == per_fan);
  for (int t = s.M - 3; t < s.M; ++t) CHECK(pixels_of[t] == 0);
  REQUIRE(s.clip[3] < 0);

  const std::vector<double> wts = random_vector(s.id.size() * s.C, -1, 1, 5);
  auto loss = [&](const std::vector<double>& a, const std::vector<double>& c, const std::vector<double>& u) {
    ClipScene t = s;
    t.attr = a;
    t.clip = c;
    t.uv = u;
    std::vector<double> out(s.id.size() * s.C);
    interpolate_forward(Typed<double>(t).params(t), out.data());
    double l = 0;
    for (std::size_t i = 0; i < out.size(); ++i) l += wts[i] * out[i];
    return l;
  };
  for (int threads : {1, 2}) {
    INFO(threads << " threads");
    const std::vector<double> grad = adjoint<double>(s, wts, threads, false);
    const std::vector<double> ga(grad.begin(), grad.begin() + s.attr.size());
    const std::vector<double> gc(grad.begin() + s.attr.size(), grad.begin() + s.attr.size() + s.clip.size());
    const std::vector<double> gu(grad.begin() + s.attr.size() + s.clip.size(), grad.end());
    const double ea = fd_error([&](const std::vector<double>& a) { return loss(a, s.clip, s.uv); }, s.attr, ga);
    const double ec = fd_error([&](const std::vector<double>& c) { return loss(s.attr, c, s.uv); }, s.clip, gc);
    const double eu = fd_error([&](const std::vector<double>& u) { return loss(s.attr, s.clip, u); }, s.uv, gu);
    INFO("relative errors attr " << ea << " clip " << ec << " uv " << eu);
    CHECK(ea < 1e-8);
    CHECK(ec < 1e-7);
    CHECK(eu < 1e-8);
    // The hub's attribute gradient gathers 24 triangles' sums: not zero.
    CHECK(ga[hub * s.C] != 0.0);
    // Vertices of empty triangles only get nothing.
    for (int v = extra; v < extra + 6; ++v)
      for (int c = 0; c < s.C; ++c) CHECK(ga[v * s.C + c] == 0.0);
  }
}
