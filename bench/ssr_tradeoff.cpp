// ssr_tradeoff: run time against hit error for both SSR tracers on the SSR scene
// (320 x 240, float32 G-buffer), measured against the dense reference tracer.
// Prints a Markdown table and writes a log-log scatter plot (PNG, drawn here
// without a plotting library): x = trace time (ms), y = mean hit error (px);
// view-space march in orange, DDA in blue, the reference as a black square at
// its time on the bottom axis.
//   ssr_tradeoff [plot.png] [repeats]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/ssr.h"
#include "ops/transforms.h"
#include "raster/image_io.h"
#include "raster/ssr_scene.h"

using namespace gr;

namespace {

constexpr int kW = 320, kH = 240;

struct Row {
  std::string tracer, params;
  double ms = 0, mean_err = 0, p95_err = 0, missed = 0, extra = 0;
  std::int64_t samples = 0;
};

// ---- A tiny canvas -----------------------------------------------------------
struct Rgb {
  float r, g, b;
};

class Canvas {
 public:
  Canvas(int w, int h) : img_(Tensor::ones({h, w, 3})), w_(w), h_(h) {}
  void put(int x, int y, Rgb c) {
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
    float* p = img_.data<float>() + 3 * (std::int64_t(y) * w_ + x);
    p[0] = c.r, p[1] = c.g, p[2] = c.b;
  }
  void rect(int x0, int y0, int x1, int y1, Rgb c) {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) put(x, y, c);
  }
  void hline(int x0, int x1, int y, Rgb c) { rect(x0, y, x1, y, c); }
  void vline(int x, int y0, int y1, Rgb c) { rect(x, y0, x, y1, c); }
  void disc(int cx, int cy, int r, Rgb c) {
    for (int y = -r; y <= r; ++y)
      for (int x = -r; x <= r; ++x)
        if (x * x + y * y <= r * r) put(cx + x, cy + y, c);
  }
  // Text in a 3 x 5 pixel font, scaled by 2; digits, '.', '-', 'e', 'm', 's', 'p', 'x'.
  void text(int x, int y, const std::string& s, Rgb c) {
    for (char ch : s) {
      const char* g = glyph(ch);
      for (int row = 0; row < 5; ++row)
        for (int col = 0; col < 3; ++col)
          if (g[row * 3 + col] == '#') rect(x + 2 * col, y + 2 * row, x + 2 * col + 1, y + 2 * row + 1, c);
      x += 8;
    }
  }
  const Tensor& image() const { return img_; }

 private:
  static const char* glyph(char c) {
    switch (c) {
      case '0': return "####.##.##.####";
      case '1': return ".#.##..#..#.###";
      case '2': return "###..#####..###";
      case '3': return "###..####..####";
      case '4': return "#.##.####..#..#";
      case '5': return "####..###..####";
      case '6': return "####..####.####";
      case '7': return "###..#..#..#..#";
      case '8': return "####.#####.####";
      case '9': return "####.####..####";
      case '.': return "............#..";
      case '-': return "......###......";
      case 'e': return "....#.####..###";
      case 'm': return "......######.##";
      case 's': return "....###.#.###..";
      case 'p': return "...####.####...";
      case 'x': return "...#.#.#.#.#...";
      default: return "...............";
    }
  }
  Tensor img_;
  int w_, h_;
};

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, v >= 1 ? "%.0f" : "%.2g", v);
  return buf;
}

Tensor plot(const std::vector<Row>& rows, double ref_ms) {
  const int W = 720, H = 480, L = 80, R = 30, T = 30, B = 60;
  Canvas c(W, H);
  double tmin = ref_ms, tmax = ref_ms, emin = 1e9, emax = 0;
  for (const Row& r : rows) {
    tmin = std::min(tmin, r.ms), tmax = std::max(tmax, r.ms);
    if (r.mean_err > 0) emin = std::min(emin, r.mean_err), emax = std::max(emax, r.mean_err);
  }
  const double lx0 = std::floor(std::log10(tmin)), lx1 = std::ceil(std::log10(tmax));
  const double ly0 = std::floor(std::log10(std::max(emin, 1e-6))), ly1 = std::ceil(std::log10(std::max(emax, 1e-5)));
  auto X = [&](double t) { return L + (std::log10(t) - lx0) / (lx1 - lx0) * (W - L - R); };
  auto Y = [&](double e) { return H - B - (std::log10(e) - ly0) / (ly1 - ly0) * (H - T - B); };
  const Rgb grid{0.87f, 0.87f, 0.87f}, black{0, 0, 0};
  for (double d = lx0; d <= lx1 + 1e-9; ++d) {
    const int x = int(X(std::pow(10, d)));
    c.vline(x, T, H - B, grid);
    c.text(x - 8, H - B + 10, fmt(std::pow(10, d)), black);
  }
  for (double d = ly0; d <= ly1 + 1e-9; ++d) {
    const int y = int(Y(std::pow(10, d)));
    c.hline(L, W - R, y, grid);
    const std::string s = fmt(std::pow(10, d));
    c.text(L - 10 - 8 * int(s.size()), y - 5, s, black);
  }
  c.vline(L, T, H - B, black);
  c.hline(L, W - R, H - B, black);
  c.text(W / 2 - 16, H - 25, "ms", black);
  c.text(10, T - 20, "px", black);
  const Rgb orange{0.9f, 0.5f, 0.1f}, blue{0.15f, 0.35f, 0.85f};
  for (const Row& r : rows) {
    if (!(r.mean_err > 0)) continue;
    c.disc(int(X(r.ms)), int(Y(r.mean_err)), r.params.find("binary 0") != std::string::npos ? 3 : 5,
           r.tracer == "dda" ? blue : orange);
  }
  const int rx = int(X(ref_ms));
  c.rect(rx - 4, H - B - 4, rx + 4, H - B + 4, black);
  // Legend in the top margin: orange = view-space, blue = DDA (small dots: no binary search).
  c.disc(W - R - 60, T / 2, 5, orange);
  c.disc(W - R - 40, T / 2, 5, blue);
  return c.image();
}

}  // namespace

int main(int argc, char** argv) {
  const std::string out = argc > 1 ? argv[1] : "ssr_tradeoff.png";
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  NoGradGuard no_grad;
  const raster::SsrScene s = raster::make_ssr_scene(8, 4);
  auto v3 = [](const std::array<double, 3>& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}); };
  const Tensor view = look_at(v3(s.eye), v3(s.target), v3(s.up));
  const Tensor proj = perspective(s.fov_y, double(kW) / kH, s.near, s.far);
  const ViewSpaceMesh vs = ssr_view_space(s.mesh.positions, s.mesh.normals, view);
  const SsrGBuffer g = ssr_gbuffer(vs.positions, vs.normals, s.colours, s.mesh.triangles, proj, {kW, kH});
  SsrOptions base;
  base.max_distance = 8;
  base.thickness = 0.3;

  // Best-of-N wall time of one full trace.
  auto timed = [&](const SsrOptions& o, SsrTrace& t) {
    double best = 1e30;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      t = ssr_trace(g, proj, o);
      best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    return best;
  };
  SsrOptions ro = base;
  ro.tracer = SsrTracer::Reference;
  SsrTrace ref;
  const double ref_ms = timed(ro, ref);

  std::vector<std::pair<std::string, SsrOptions>> configs;
  for (int steps : {16, 32, 64, 128, 256})
    for (int bs : {0, 4}) {
      SsrOptions o = base;
      o.tracer = SsrTracer::ViewSpace, o.max_steps = steps, o.binary_steps = bs;
      configs.push_back({"steps " + std::to_string(steps) + ", binary " + std::to_string(bs), o});
    }
  for (int stride : {1, 2, 4, 8})
    for (int bs : {0, 4}) {
      SsrOptions o = base;
      o.tracer = SsrTracer::Dda, o.max_steps = 1024, o.stride = stride, o.binary_steps = bs;
      o.jitter = stride > 1 ? 1.0 : 0.0;
      configs.push_back({"stride " + std::to_string(stride) + ", binary " + std::to_string(bs), o});
    }

  std::vector<Row> rows;
  const float *rh = ref.hit.data<float>(), *rxy = ref.hit_xy.data<float>();
  for (const auto& [params, o] : configs) {
    SsrTrace t;
    Row row;
    row.tracer = o.tracer == SsrTracer::Dda ? "dda" : "view-space";
    row.params = params;
    row.ms = timed(o, t);
    row.samples = t.stats.samples;
    const float *h = t.hit.data<float>(), *xy = t.hit_xy.data<float>();
    std::vector<double> errs;
    std::int64_t ref_hits = 0, missed = 0, extra = 0;
    for (std::int64_t k = 0; k < t.hit.numel(); ++k) {
      ref_hits += rh[k] != 0;
      if (rh[k] && h[k]) errs.push_back(std::hypot(xy[2 * k] - rxy[2 * k], xy[2 * k + 1] - rxy[2 * k + 1]));
      missed += rh[k] && !h[k];
      extra += !rh[k] && h[k];
    }
    std::sort(errs.begin(), errs.end());
    double sum = 0;
    for (double e : errs) sum += e;
    row.mean_err = errs.empty() ? 0 : sum / errs.size();
    row.p95_err = errs.empty() ? 0 : errs[errs.size() * 95 / 100];
    row.missed = 100.0 * missed / std::max<std::int64_t>(1, ref_hits);
    row.extra = 100.0 * extra / std::max<std::int64_t>(1, ref_hits);
    rows.push_back(row);
  }

  std::printf("SSR scene %d x %d, %lld rays, reference: %lld hits, %.1f ms (best of %d)\n\n", kW, kH,
              (long long)ref.stats.rays, (long long)ref.stats.hits, ref_ms, repeats);
  std::printf("| tracer | parameters | time (ms) | depth samples | mean err (px) | p95 err (px) | missed (%%) | extra (%%) |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows)
    std::printf("| %s | %s | %.2f | %lld | %.3f | %.3f | %.2f | %.2f |\n", r.tracer.c_str(), r.params.c_str(), r.ms,
                (long long)r.samples, r.mean_err, r.p95_err, r.missed, r.extra);
  raster::write_png(out, plot(rows, ref_ms));
  std::printf("\nplot: %s\n", out.c_str());
  return 0;
}
