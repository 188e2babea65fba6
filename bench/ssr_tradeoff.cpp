// ssr_tradeoff: run time against hit error for both SSR tracers on the SSR scene
// (320 x 240, float32 G-buffer), measured against the dense reference tracer.
// Prints a Markdown table and writes a log-log scatter plot (PNG, drawn with
// examples/common/plot_canvas.h, no plotting library): x = trace time (ms), y = mean hit error (px);
// view-space march in orange, DDA in blue, the reference as a black square at
// its time on the bottom axis.
//   ssr_tradeoff [plot.png] [repeats]   (--help for usage)
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "examples/common/cli_args.h"
#include "examples/common/plot_canvas.h"
#include "ops/render/ssr.h"
#include "ops/render/transforms.h"
#include "raster/io/image_io.h"
#include "examples/common/ssr_scene.h"
#include "raster/temporaries.h"

using namespace gr;

namespace {

constexpr int kW = 320, kH = 240;

struct Row {
  std::string tracer, params;
  double ms = 0, mean_err = 0, p95_err = 0, missed = 0, extra = 0;
  std::int64_t samples = 0;
};

using plot::Rgb;

plot::LogLogPlot make_plot(const std::vector<Row>& rows, double ref_ms) {
  double tmin = ref_ms, tmax = ref_ms, emin = 1e9, emax = 0;
  for (const Row& r : rows) {
    tmin = std::min(tmin, r.ms), tmax = std::max(tmax, r.ms);
    if (r.mean_err > 0) emin = std::min(emin, r.mean_err), emax = std::max(emax, r.mean_err);
  }
  plot::LogLogPlot p(tmin, tmax, std::max(emin, 1e-6), std::max(emax, 1e-5), "ms", "px");
  plot::Canvas& c = p.canvas();
  const plot::PlotFrame& f = p.frame();
  const Rgb orange{0.9f, 0.5f, 0.1f}, blue{0.15f, 0.35f, 0.85f}, black{0, 0, 0};
  for (const Row& r : rows) {
    if (!(r.mean_err > 0)) continue;
    c.disc(int(p.x(r.ms)), int(p.y(r.mean_err)), r.params.find("binary 0") != std::string::npos ? 3 : 5,
           r.tracer == "dda" ? blue : orange);
  }
  const int rx = int(p.x(ref_ms)), axis_y = f.height - f.bottom;
  c.rect(rx - 4, axis_y - 4, rx + 4, axis_y + 4, black);
  // Legend in the top margin: orange = view-space, blue = DDA (small dots: no binary search).
  c.disc(f.width - f.right - 60, f.top / 2, 5, orange);
  c.disc(f.width - f.right - 40, f.top / 2, 5, blue);
  return p;
}

// [PLOT.png] [REPEATS] as given, or a usage error (exit 2).
struct Arguments {
  std::string out = "ssr_tradeoff.png";
  int repeats = 5;
  bool help = false;
};

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  std::vector<std::string> positional;
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") {
      a.help = true;
      return a;
    }
    if (arg.rfind("-", 0) == 0) throw cli::UsageError("unknown option " + cli::quoted(arg));
    positional.push_back(arg);
  }
  if (positional.size() > 2) throw cli::UsageError("unexpected argument " + cli::quoted(positional[2]));
  if (!positional.empty()) a.out = positional[0];
  if (positional.size() > 1) a.repeats = cli::parse_int("REPEATS", positional[1], 1, 1000);
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  raster::remove_temporaries_on_signals();
  const char* usage =
      "Usage: ssr_tradeoff [PLOT.png [REPEATS]]\n"
      "Times both SSR tracers against the dense reference, prints a table and writes a log-log plot\n"
      "(default ssr_tradeoff.png); REPEATS: best-of-N timing, 1..1000 (default 5).\n"
      "Exit codes: 0 success, 1 runtime error, 2 usage error.\n";
  Arguments arguments;
  try {
    arguments = parse_arguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "ssr_tradeoff: %s\n\n%s", e.what(), usage);
    return 2;
  }
  if (arguments.help) {
    std::fputs(usage, stdout);
    return 0;
  }
  const std::string out = arguments.out;
  const int repeats = arguments.repeats;
  NoGradGuard no_grad;
  const gr::examples::SsrScene s = gr::examples::make_ssr_scene(8, 4);
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
  raster::write_png(out, make_plot(rows, ref_ms).image());
  std::printf("\nplot: %s\n", out.c_str());
  return 0;
}
