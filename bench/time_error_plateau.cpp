// time_error_plateau (issue 13): why the antialiased position-gradient error of
// time_error stops falling with supersampling (docs/time_error.md, "Why the
// error stalls with supersampling"). For one scene it computes the exact
// reference's per-pixel directional derivatives dB/dv_k (4th-order finite
// differences of the exact box-filtered image, time_error's 16 directions),
// then for supersampling s = 1, 2, 3, 4, 6, 8, 16 the float64 gradient of
//   mse      mean((R_s - T)^2), time_error's loss,
//   linear   sum(w R_s) with w = 2 (B - T) / N fixed: the same reference
//            derivative (dL/dv = sum w dB/dv), but no residual R_s - B,
// and splits the linear error by pixel region (bench/time_error_regions.h:
// pixels holding a background boundary, a depth jump, a change of object
// without one, none of these).
//   time_error_plateau [--scene NAME] [--vis] [--plain] [--flat] [--colours ring|tube] [--sum] [--step PX] [--order Q] [--s 1,2,4,...]
//   --flat: one colour per object (the interior colour term vanishes);
//   --colours ring|tube: torus colours varying only around the ring / the tube;
//   --plain: no antialias (the interior colour term alone);
//   --sum: linear weights w = 1 / N (the image mean) instead of the residual's
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "bench/time_error_exact.h"
#include "bench/time_error_reference.h"
#include "bench/time_error_regions.h"
#include "bench/time_error_scene.h"
#include "examples/common/cli_args.h"
#include "ops/ops.h"

using namespace gr;
using namespace gr::bench;

namespace {

struct Options {
  std::string scene = "torus";
  bool vis = false, flat = false, plain = false, sum_weights = false;
  std::string colours;  // "", "ring" or "tube" (torus only)
  std::vector<int> s_list{1, 2, 3, 4, 6, 8, 16};
  double step_px = kExactPositionStepPx;
  int order = 8;
};

// One colour per object: each part's mean colour.
Tensor flat_colours(const TimeErrorScene& scene) {
  const std::vector<double> c = scene.colours().to_vector();
  const std::int32_t* part = scene.point_part().data<std::int32_t>();
  const std::int64_t n = scene.num_points();
  std::vector<double> sum(3 * scene.num_parts(), 0.0), count(scene.num_parts(), 0.0), out(c.size());
  for (std::int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) sum[3 * part[i] + k] += c[3 * i + k];
    count[part[i]] += 1;
  }
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + k] = sum[3 * part[i] + k] / count[part[i]];
  return Tensor::from_values(out, {n, 3}, DType::Float64);
}

// Screen widths (px, at 1x) of the front-facing triangles at fold edges
// (both triangles of the edge on the same screen side of it): the distance of
// the third vertex from the edge's line. Prints quantiles.
void print_fold_widths(const TimeErrorScene& scene) {
  NoGradGuard no_grad;
  const std::vector<double> c = scene.clip_positions(scene.points()).to_vector();
  const std::int32_t* t = scene.triangles().data<std::int32_t>();
  const std::int64_t m = scene.num_triangles();
  auto xy = [&](std::int32_t v, int k) {
    const double ndc = c[4 * v + k] / c[4 * v + 3];
    return k == 0 ? 0.5 * scene.width() * (1 + ndc) : 0.5 * scene.height() * (1 - ndc);
  };
  auto key = [&](std::int32_t v) { return std::array<double, 2>{c[4 * v], c[4 * v + 1]}; };
  std::map<std::pair<std::array<double, 2>, std::array<double, 2>>, std::vector<std::pair<std::int64_t, int>>> edges;
  for (std::int64_t i = 0; i < m; ++i)
    for (int k = 0; k < 3; ++k) {
      auto a = key(t[3 * i + (k + 1) % 3]), b = key(t[3 * i + (k + 2) % 3]);
      if (b < a) std::swap(a, b);
      edges[{a, b}].push_back({i, k});
    }
  std::vector<double> widths;
  for (const auto& [e, tris] : edges) {
    if (tris.size() != 2) continue;
    double side[2], width[2], area[2];
    for (int j = 0; j < 2; ++j) {
      const std::int32_t* tri = t + 3 * tris[j].first;
      const int k = tris[j].second;
      std::int32_t a = tri[(k + 1) % 3], b = tri[(k + 2) % 3];
      const std::int32_t o = tri[k];
      if (key(b) < key(a)) std::swap(a, b);  // one orientation for both triangles
      const double ex = xy(b, 0) - xy(a, 0), ey = xy(b, 1) - xy(a, 1);
      const double cr = (xy(o, 0) - xy(a, 0)) * ey - (xy(o, 1) - xy(a, 1)) * ex;
      side[j] = cr, width[j] = std::abs(cr) / std::hypot(ex, ey);
      area[j] = (xy(tri[1], 0) - xy(tri[0], 0)) * (xy(tri[2], 1) - xy(tri[0], 1)) -
                (xy(tri[1], 1) - xy(tri[0], 1)) * (xy(tri[2], 0) - xy(tri[0], 0));
    }
    if (side[0] * side[1] <= 0) continue;  // not a fold
    widths.push_back(area[0] < 0 ? width[0] : width[1]);  // screen y down: front (CCW in NDC) has area < 0 here
  }
  std::sort(widths.begin(), widths.end());
  std::printf("fold edges: %zu; front triangle's screen width (px at 1x): ", widths.size());
  for (double q : {0.1, 0.25, 0.5, 0.75, 0.9})
    std::printf("q%.2g %.3g  ", q, widths[std::size_t(q * (widths.size() - 1))]);
  for (double lim : {0.0625, 0.125, 0.25, 0.5})
    std::printf(" <%.3g px: %.0f%%", lim,
                100.0 * double(std::lower_bound(widths.begin(), widths.end(), lim) - widths.begin()) / widths.size());
  std::printf("\n");
}

// Torus colours varying only around the ring (constant across the tube, so
// across every contour triangle) or only around the tube (the time_error
// torus' tube bands and a fixed Lambert-like ramp).
Tensor torus_colours(const TimeErrorScene& scene, const std::string& kind) {
  const std::vector<double> p = scene.points().to_vector();
  std::vector<double> out(p.size());
  for (std::size_t i = 0; i < p.size(); i += 3) {
    const double around = std::atan2(p[i + 2], p[i]), tube = std::atan2(p[i + 1], std::hypot(p[i], p[i + 2]) - 1.0);
    if (kind == "ring")
      out[i] = 0.55 + 0.4 * std::cos(3 * around), out[i + 1] = 0.55 + 0.4 * std::cos(3 * around + 2.1), out[i + 2] = 0.5;
    else
      out[i] = 0.5 + 0.35 * std::sin(8 * tube), out[i + 1] = 0.5 + 0.3 * std::cos(tube), out[i + 2] = 0.5;
  }
  return Tensor::from_values(out, {scene.num_points(), 3}, DType::Float64);
}

// The command line (see the top of this file); throws cli::UsageError. False at --help.
bool parse_options(const std::vector<std::string>& args, Options& o) {
  using cli::fail;
  std::set<std::string> seen;
  return cli::for_each_flag(
      args, {{"--scene", "--step", "--order", "--colours", "--s"}, {"--vis", "--flat", "--plain", "--sum"}},
      [&](const std::string& flag, const std::string& v) {
        if (flag == "--vis") o.vis = true;
        else if (flag == "--flat") o.flat = true;
        else if (flag == "--plain") o.plain = true;
        else if (flag == "--sum") o.sum_weights = true;
        else if (flag == "--scene") {
          const std::vector<std::string>& names = time_error_scene_names();
          if (std::find(names.begin(), names.end(), v) == names.end())
            fail(flag, "expected torus, intersection, occlusion or open_culled, got " + cli::quoted(v));
          o.scene = v;
        } else if (flag == "--step") {
          o.step_px = cli::parse_number(flag, v);
          if (!(o.step_px > 0)) fail(flag, "must be positive, got " + v);
        } else if (flag == "--order") {
          o.order = cli::parse_int(flag, v, 1, 32);
        } else if (flag == "--colours") {
          if (v != "ring" && v != "tube") fail(flag, "expected ring or tube, got " + cli::quoted(v));
          o.colours = v;
        } else {  // --s: a comma-separated list of supersampling factors
          o.s_list.clear();
          std::size_t at = 0;
          for (;;) {
            const std::size_t comma = v.find(',', at);
            o.s_list.push_back(cli::parse_int(flag, v.substr(at, comma - at), 1, 64));
            if (comma == std::string::npos) break;
            at = comma + 1;
          }
        }
      },
      seen);
}

}  // namespace

int main(int argc, char** argv) {
  set_num_threads(2);
  Options o;
  try {
    if (!parse_options(std::vector<std::string>(argv + 1, argv + argc), o)) {
      std::printf("usage: time_error_plateau [--scene NAME] [--vis] [--plain] [--flat] [--colours ring|tube] [--sum]\n"
                  "                          [--step PX] [--order Q] [--s 1,2,4,...]   (see docs/time_error.md)\n");
      return 0;
    }
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "time_error_plateau: %s\n(run time_error_plateau --help for usage)\n", e.what());
    return 2;
  }
  const TimeErrorScene scene(o.scene);
  print_fold_widths(scene);
  const Tensor colours = o.flat ? flat_colours(scene) : !o.colours.empty() ? torus_colours(scene, o.colours) : scene.colours();
  const Directions dirs = random_directions(scene.points(), 16, 0, 6);
  ExactReferenceOptions eo;
  eo.quadrature_order = o.order;
  std::vector<double> B, T;
  {
    NoGradGuard no_grad;
    B = exact_scene_image(scene, scene.points(), colours, eo).image.to_vector();
    T = exact_scene_image(scene, scene.target_points(), colours, eo).image.to_vector();
  }
  const std::size_t N = B.size();
  std::vector<double> w(N);
  for (std::size_t i = 0; i < N; ++i) w[i] = o.sum_weights ? 1.0 / double(N) : 2 * (B[i] - T[i]) / double(N);
  // Per-pixel derivatives of the exact image along each direction.
  const double h = o.step_px / (std::sqrt(2.0) * scene.pixels_per_unit());
  std::vector<std::vector<double>> dB;
  std::vector<double> ref, ref_h, ref_2h;
  {
    NoGradGuard no_grad;
    for (const Tensor& v : dirs.position) {
      auto img = [&](double t) { return exact_scene_image(scene, scene.points() + t * v, colours, eo).image.to_vector(); };
      const std::vector<double> p1 = img(h), m1 = img(-h), p2 = img(2 * h), m2 = img(-2 * h);
      std::vector<double> d(N);
      double r = 0, rh = 0, r2h = 0;
      for (std::size_t i = 0; i < N; ++i) {
        d[i] = (8 * (p1[i] - m1[i]) - (p2[i] - m2[i])) / (12 * h);
        r += w[i] * d[i], rh += w[i] * (p1[i] - m1[i]) / (2 * h), r2h += w[i] * (p2[i] - m2[i]) / (4 * h);
      }
      dB.push_back(std::move(d));
      ref.push_back(r), ref_h.push_back(rh), ref_2h.push_back(r2h);
    }
  }
  const std::vector<int> region = pixel_regions(scene, scene.points());
  int counts[kNumPixelRegions] = {};
  for (int r : region) ++counts[r];
  std::printf("scene %s, %s, colours %s, step %.3g px, quadrature %d; h vs 2h spread %.2g\n", o.scene.c_str(),
              o.vis ? "visibility_antialias" : "antialias", o.flat ? "flat" : !o.colours.empty() ? o.colours.c_str() : "as time_error", o.step_px, o.order,
              relative_l2(ref_h, ref_2h));
  std::printf("pixels: %d interior, %d background boundary, %d depth jump, %d object change\n\n", counts[0], counts[1],
              counts[2], counts[3]);
  // Each region's share of the reference: |r_region| / |r|.
  std::printf("reference share by region:");
  for (int g = 0; g < kNumPixelRegions; ++g) {
    std::vector<double> rg;
    for (const auto& d : dB) {
      double s = 0;
      for (std::size_t i = 0; i < N; ++i) s += region[i / 3] == g ? w[i] * d[i] : 0.0;
      rg.push_back(s);
    }
    double a = 0, b = 0;
    for (std::size_t k = 0; k < rg.size(); ++k) a += rg[k] * rg[k], b += ref[k] * ref[k];
    std::printf(" %.3g", std::sqrt(a / b));
  }
  std::printf("\n\n| s | mse error | linear error | linear: interior | background boundary | depth jump | object change |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|\n");
  const Tensor target = Tensor::from_values(T, {scene.height(), scene.width(), 3}, DType::Float64);
  std::vector<std::vector<std::vector<double>>> proj;  // [s][region + 1][direction]
  for (int s : o.s_list) {
    const RenderSettings rs{DType::Float64, !o.plain, s, 0, o.vis};
    proj.emplace_back();
    Tensor p = scene.points().detach().set_requires_grad();
    backward(scene.loss(p, colours, target, rs));
    const double mse_err = relative_l2(project(p.grad(), dirs.position), ref);
    std::printf("| %d | %.3g | ", s, mse_err);
    // Linear loss, all pixels, then each region alone.
    for (int g = -1; g < kNumPixelRegions; ++g) {
      std::vector<double> wg(w);
      for (std::size_t i = 0; i < N; ++i)
        if (g >= 0 && region[i / 3] != g) wg[i] = 0;
      std::vector<double> rg(dB.size(), 0.0);
      for (std::size_t k = 0; k < dB.size(); ++k)
        for (std::size_t i = 0; i < N; ++i) rg[k] += wg[i] * dB[k][i];
      Tensor q = scene.points().detach().set_requires_grad();
      const Tensor wt = Tensor::from_values(wg, {scene.height(), scene.width(), 3}, DType::Float64);
      backward(sum(scene.render(q, colours, rs) * wt));
      const std::vector<double> pg = project(q.grad(), dirs.position);
      proj.back().push_back(pg);
      double num = 0, den = 0;  // region error relative to the whole reference
      for (std::size_t k = 0; k < pg.size(); ++k) num += (pg[k] - rg[k]) * (pg[k] - rg[k]), den += ref[k] * ref[k];
      std::printf("%.3g |%s", std::sqrt(num / den), g == kNumPixelRegions - 1 ? "\n" : " ");
    }
    std::fflush(stdout);
  }
  // The hybrid oracle (docs/time_error.md, "What 1% at 1x would cost"): an
  // image exact on the pixels holding a boundary and point-sampled at 1x
  // (no antialias) on the others, graded on time_error's loss; its gradient
  // takes the exact per-pixel derivatives dB on the boundary pixels.
  if (!o.sum_weights) {
    Tensor q = scene.points().detach().set_requires_grad();
    const Tensor R = scene.render(q, colours, RenderSettings{DType::Float64, false, 1});
    const std::vector<double> r = R.to_vector();
    std::vector<double> wh(N), w_interior(N, 0.0);
    for (std::size_t i = 0; i < N; ++i) {
      const bool interior = region[i / 3] == kInterior;
      wh[i] = 2 * ((interior ? r[i] : B[i]) - T[i]) / double(N);
      if (interior) w_interior[i] = wh[i];
    }
    backward(sum(R * Tensor::from_values(w_interior, R.shape(), DType::Float64)));
    std::vector<double> hybrid = project(q.grad(), dirs.position);
    for (std::size_t k = 0; k < hybrid.size(); ++k)
      for (std::size_t i = 0; i < N; ++i)
        if (region[i / 3] != kInterior) hybrid[k] += wh[i] * dB[k][i];
    std::printf("\nhybrid oracle (exact on the %d boundary pixels, point-sampled 1x elsewhere): mse error %.3g\n",
                counts[1] + counts[2] + counts[3], relative_l2(hybrid, ref));
  }
  // Self-convergence: each s against the last one, per region, relative to |reference|.
  std::printf("\nagainst s = %d (same regions, relative to the whole reference):\n", o.s_list.back());
  double den = 0;
  for (double r : ref) den += r * r;
  for (std::size_t i = 0; i + 1 < proj.size(); ++i) {
    std::printf("| %d |", o.s_list[i]);
    for (int g = 0; g <= kNumPixelRegions; ++g) {  // all pixels, then each region
      double num = 0;
      for (std::size_t k = 0; k < ref.size(); ++k) {
        const double d = proj[i][g][k] - proj.back()[g][k];
        num += d * d;
      }
      std::printf(" %.3g |", std::sqrt(num / den));
    }
    std::printf("\n");
  }
  return 0;
}
