// time_error (issue 6; graded exactly since issue 13): run time against
// gradient error for float32/float64, antialiasing off/on (antialias or, rows "vis",
// visibility_antialias), supersampling
// 1/2/4 and soft rasterization at three sigmas on four fixed scenes at
// 128 x 128, each fitted towards a copy with its objects rotated and shifted,
// loss = MSE (bench/time_error_scene.h): a torus (silhouettes), a sphere sunk
// into a square (an intersection curve), a sphere in front of another
// (occlusion), an open bowl drawn with back faces culled. Each configuration's gradient w.r.t. the vertex
// positions and colours is compared with float64 finite differences of the
// area-integrated loss: by default that of the exact box-filtered image
// (bench/time_error_exact.h), with --supersampled-reference that of a 16x16
// supersampled render with antialiasing (bench/time_error_reference.h); its
// image with the reference image. Prints a Markdown table per scene, writes
// one CSV (a scene column) and per scene a log-log plot of time against
// position-gradient error with the Pareto frontier. docs/time_error.md
// explains the scenes, the reference and the results.
//
//   time_error [--scene NAME] [--supersampled-reference] [out.csv] [out.png]   (--help: bench/time_error_args.h)
//        defaults: all four scenes in sequence, out/time_error.csv, out/time_error.png;
//        the torus' plot goes to out.png, another scene's to <out>_<scene>.png
//   time_error [--scene NAME] --convergence       the supersampled reference's convergence study (slow; prints only)
//   time_error [--scene NAME] --soft-consistency  soft rasterization's gradient against FD of its own loss
//   (--convergence and --soft-consistency default to the torus)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "bench/time_error_args.h"
#include "bench/time_error_exact.h"
#include "bench/time_error_plot.h"
#include "bench/time_error_reference.h"
#include "bench/time_error_scene.h"
#include "ops/ops.h"
#include "examples/common/cli_args.h"
#include "raster/io/files.h"
#include "raster/io/image_io.h"
#include "raster/temporaries.h"

using namespace gr;
using namespace gr::bench;

namespace {

constexpr int kThreads = 2;
constexpr int kTimedRuns = 7;
constexpr int kPositionDirections = 16;
constexpr int kColourDirections = 6;
constexpr std::uint64_t kSeed = 6;

const char* short_dtype(DType d) { return d == DType::Float64 ? "f64" : "f32"; }

// Sigma as printed: "0.3".
std::string sigma_text(double sigma) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", sigma);
  return text;
}

std::string config_name(const RenderSettings& s) {
  if (s.soft_sigma > 0) return std::string(short_dtype(s.dtype)) + " soft " + sigma_text(s.soft_sigma);
  const char* edges = !s.antialias ? "" : s.visibility ? " vis" : " aa";
  return std::string(short_dtype(s.dtype)) + edges + " s" + std::to_string(s.supersample);
}

bool same_except_dtype(const RenderSettings& a, const RenderSettings& b) {
  return a.antialias == b.antialias && a.supersample == b.supersample && a.soft_sigma == b.soft_sigma &&
         a.visibility == b.visibility;
}

// The soft rasterizer's sigmas (pixels^2): edge transitions about
// 2 sqrt(sigma) = 0.6, 1.1 and 2 px wide (docs/soft_rasterize.md).
constexpr double kSoftSigmas[] = {0.1, 0.3, 1.0};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Root mean square of a - b over all elements, in double.
double rms_difference(const Tensor& a, const Tensor& b) {
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  double s = 0;
  for (std::size_t i = 0; i < x.size(); ++i) s += (x[i] - y[i]) * (x[i] - y[i]);
  return std::sqrt(s / double(x.size()));
}

struct Gradients {
  Tensor position, colour;  // [P, 3] of the settings' dtype
  double loss = 0;
};

// One forward + backward of the loss at the scene's parameters.
Gradients gradients(const TimeErrorScene& scene, const Tensor& target, const RenderSettings& settings) {
  Tensor points = cast(scene.points(), settings.dtype).detach().set_requires_grad();
  Tensor colours = cast(scene.colours(), settings.dtype).detach().set_requires_grad();
  const Tensor t = settings.dtype == DType::Float64 ? target : cast(target, settings.dtype);
  const Tensor loss = scene.loss(points, colours, t, settings);
  backward(loss);
  return {points.grad(), colours.grad(), loss.item()};
}

struct Row {
  std::string scene;
  RenderSettings settings;
  double ms = 0, cpu_ms = 0, position_error = 0, colour_error = 0, image_error = 0, loss = 0;
  bool pareto = false;
  std::vector<double> position_projections;  // grad . v_k, for comparing dtypes
};

// Errors of one configuration (the timing is done separately, interleaved).
Row measure_errors(const TimeErrorScene& scene, const Tensor& target, const Tensor& reference_image,
                   const Directions& directions, const ReferenceDerivatives& reference,
                   const RenderSettings& settings) {
  Row row;
  row.scene = scene.name();
  row.settings = settings;
  const Gradients g = gradients(scene, target, settings);
  row.loss = g.loss;
  row.position_projections = project(g.position, directions.position);
  row.position_error = relative_l2(row.position_projections, reference.position);
  row.colour_error = relative_l2(project(g.colour, directions.colour), reference.colour);
  NoGradGuard no_grad;
  row.image_error = rms_difference(scene.render(cast(scene.points(), settings.dtype),
                                                cast(scene.colours(), settings.dtype), settings),
                                   reference_image);
  return row;
}

// Median forward+backward time of each row's configuration. The runs are
// interleaved (round r times every configuration once), so a change in the
// machine's load during the sweep hits all configurations alike. CPU time
// (both threads' total) is kept too: unlike wall time it barely moves when other
// jobs share the cores.
void measure_times(const TimeErrorScene& scene, const Tensor& target, std::vector<Row>& rows) {
  std::vector<std::vector<double>> wall(rows.size()), cpu(rows.size());
  for (int r = 0; r < kTimedRuns; ++r)
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::clock_t c0 = std::clock();
      gradients(scene, target, rows[i].settings);
      cpu[i].push_back(1e3 * double(std::clock() - c0) / CLOCKS_PER_SEC);
      wall[i].push_back(1e3 * seconds_since(t0));
    }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i].ms = median(wall[i]), rows[i].cpu_ms = median(cpu[i]);
}

// Written as one raster::OutputSet: all or nothing, never into a FIFO or through a symlink.
void write_csv(const std::string& path, const std::vector<Row>& rows) {
  std::ostringstream out;
  out << "scene,config,dtype,antialias,visibility,supersample,soft_sigma,ms,cpu_ms,grad_rel_error,colour_grad_rel_error,image_rmse,loss,pareto\n";
  char line[512];
  for (const Row& r : rows) {
    std::snprintf(line, sizeof line, "%s,%s,%s,%d,%d,%d,%g,%.4f,%.4f,%.6g,%.6g,%.6g,%.9g,%d\n", r.scene.c_str(),
                  config_name(r.settings).c_str(),
                  short_dtype(r.settings.dtype), int(r.settings.antialias), int(r.settings.visibility),
                  r.settings.supersample,
                  r.settings.soft_sigma, r.ms, r.cpu_ms,
                  r.position_error, r.colour_error, r.image_error, r.loss, int(r.pareto));
    out << line;
  }
  const std::string text = out.str();
  raster::OutputSet csv;
  csv.stage(path, text.data(), text.size());
  csv.commit();
}

void ensure_parent(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
}

// The 16x16 supersampled reference of --supersampled-reference and --convergence.
constexpr RenderSettings kSupersampledReference{DType::Float64, true, 16};

Tensor render_reference(const TimeErrorScene& scene, const Tensor& points, const RenderSettings& settings) {
  NoGradGuard no_grad;
  return scene.render(points, scene.colours(), settings);
}

// What the configurations are graded against: the target image of the loss,
// the reference image at the scene's parameters, and the loss's directional
// derivatives by finite differences.
struct Reference {
  Tensor target, image;
  ReferenceDerivatives derivatives;
  FiniteDifferenceSteps steps;
};

Reference exact_reference(const TimeErrorScene& scene, const Directions& directions) {
  Reference r;
  r.target = exact_scene_image(scene, scene.target_points(), scene.colours()).image;
  r.image = exact_scene_image(scene, scene.points(), scene.colours()).image;
  r.steps.position_px = kExactPositionStepPx;
  r.derivatives = finite_difference_reference(scene, exact_scene_loss(scene, r.target), directions, r.steps);
  return r;
}

Reference supersampled_reference(const TimeErrorScene& scene, const Directions& directions) {
  Reference r;
  r.target = render_reference(scene, scene.target_points(), kSupersampledReference);
  r.image = render_reference(scene, scene.points(), kSupersampledReference);
  r.derivatives = finite_difference_reference(scene, rendered_loss(scene, r.target, kSupersampledReference),
                                              directions, r.steps);
  return r;
}

// [H, W, 3] a and b -> [H, 2W + 4, 3] float32, a on the left, b on the right, a white gap.
Tensor side_by_side(const Tensor& a, const Tensor& b) {
  const std::int64_t h = a.size(0), w = a.size(1), out_w = 2 * w + 4;
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  std::vector<float> out(static_cast<std::size_t>(h * out_w * 3), 1.0f);
  for (std::int64_t i = 0; i < h; ++i)
    for (std::int64_t j = 0; j < w; ++j)
      for (int c = 0; c < 3; ++c) {
        out[(i * out_w + j) * 3 + c] = float(x[(i * w + j) * 3 + c]);
        out[(i * out_w + w + 4 + j) * 3 + c] = float(y[(i * w + j) * 3 + c]);
      }
  return Tensor::from_vector(out, {h, out_w, 3});
}

// One scene's sweep: prints its table, writes its plot, appends its rows.
void sweep_scene(const std::string& name, bool supersampled, const std::string& png_path, std::vector<Row>& all_rows) {
  const auto start = std::chrono::steady_clock::now();
  const TimeErrorScene scene(name);
  const Directions directions = random_directions(scene.points(), kPositionDirections, kColourDirections, kSeed);
  const Reference ref = supersampled ? supersampled_reference(scene, directions) : exact_reference(scene, directions);
  const Tensor& target = ref.target;
  std::printf("## scene %s: %s\n\n%lld points, %lld triangles, %d x %d, cull %s, loss = MSE against the "
              "rotated and shifted objects\n",
              scene.name().c_str(), scene.description().c_str(), (long long)scene.num_points(),
              (long long)scene.num_triangles(), scene.width(), scene.height(),
              scene.cull() == raster::Cull::None ? "none" : "back faces");
  if (supersampled)
    std::printf("reference: float64, antialias, %dx%d supersampling,", kSupersampledReference.supersample,
                kSupersampledReference.supersample);
  else
    std::printf("reference: float64, exact box-filtered image (bench/exact_reference),");
  std::printf(" 4th-order central differences along %d random\n"
              "  position directions (step %.3g px) and %d colour directions; %.1f s. "
              "2nd-order h vs 2h spread: %.2g\n\n",
              kPositionDirections, ref.steps.position_px, kColourDirections, ref.derivatives.seconds,
              relative_l2(ref.derivatives.position_h, ref.derivatives.position_2h));

  std::vector<Row> rows;  // the error pass doubles as the warm-up of the storage cache
  for (DType dtype : {DType::Float32, DType::Float64}) {
    for (bool aa : {false, true})
      for (int ss : {1, 2, 4})
        rows.push_back(measure_errors(scene, target, ref.image, directions, ref.derivatives, {dtype, aa, ss}));
    for (int ss : {1, 2, 4})  // visibility_antialias (issue 13 item 2)
      rows.push_back(measure_errors(scene, target, ref.image, directions, ref.derivatives, {dtype, true, ss, 0, true}));
    if (scene.cull() == raster::Cull::None)  // soft_rasterize cannot cull
      for (double sigma : kSoftSigmas)
        rows.push_back(measure_errors(scene, target, ref.image, directions, ref.derivatives, {dtype, false, 1, sigma}));
  }
  measure_times(scene, target, rows);

  std::vector<FrontierPoint> points;
  for (const Row& r : rows)
    points.push_back({r.settings.soft_sigma > 0 ? "soft " + sigma_text(r.settings.soft_sigma)
                                                : (!r.settings.antialias ? "x" : r.settings.visibility ? "vis x" : "aa x") +
                                                      std::to_string(r.settings.supersample),
                      r.ms, r.position_error, r.settings.dtype == DType::Float64, r.settings.antialias,
                      r.settings.antialias && r.settings.visibility});
  for (std::size_t i : pareto_frontier(points)) rows[i].pareto = true;

  std::printf("forward+backward: median of %d interleaved runs, %d threads\n\n", kTimedRuns, kThreads);
  std::printf("| config | dtype | aa | ss | soft sigma | ms | cpu ms | grad rel error (positions) "
              "| grad rel error (colours) | image error (RMS) | pareto |\n");
  std::printf("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n");
  for (const Row& r : rows)
    std::printf("| %s | %s | %s | %d | %s | %.2f | %.2f | %.3g | %.3g | %.3g | %s |\n",
                config_name(r.settings).c_str(), short_dtype(r.settings.dtype),
                !r.settings.antialias ? "off" : r.settings.visibility ? "vis" : "on",
                r.settings.supersample, r.settings.soft_sigma > 0 ? sigma_text(r.settings.soft_sigma).c_str() : "",
                r.ms,
                r.cpu_ms, r.position_error, r.colour_error, r.image_error, r.pareto ? "yes" : "");
  // Rounding alone: each float32 configuration against the float64 one with the same settings.
  std::printf("\nfloat32 against float64 with the same settings (relative L2 of the position projections):");
  for (const Row& a : rows)
    for (const Row& b : rows)
      if (a.settings.dtype == DType::Float32 && b.settings.dtype == DType::Float64 &&
          same_except_dtype(a.settings, b.settings))
        std::printf(" %s %.2g;", config_name(a.settings).substr(4).c_str(),
                    relative_l2(a.position_projections, b.position_projections));
  std::printf("\n");
  const std::string png = time_error_plot_path(png_path, scene.name());
  ensure_parent(png);
  raster::write_png(png, plot_frontier(points, "grad err (" + scene.name() + ")"));
  const std::string pictures = time_error_picture_path(png_path, scene.name());
  raster::write_png(pictures, side_by_side(ref.image, ref.target));
  std::printf("\nwrote %s and %s; scene total %.1f s\n\n", png.c_str(), pictures.c_str(), seconds_since(start));
  std::fflush(stdout);
  all_rows.insert(all_rows.end(), rows.begin(), rows.end());
}

int run_sweep(const std::vector<std::string>& scenes, bool supersampled, const std::string& csv_path,
              const std::string& png_path) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<Row> rows;
  for (const std::string& name : scenes) sweep_scene(name, supersampled, png_path, rows);
  ensure_parent(csv_path);
  write_csv(csv_path, rows);
  std::printf("wrote %s; total %.1f s\n", csv_path.c_str(), seconds_since(start));
  return 0;
}

// How the reference depends on its supersampling and step, and how far the
// float64 analytic gradients are from it (docs/time_error.md). Fewer
// directions than the sweep, to keep it to a few minutes.
int run_convergence(const std::string& name) {
  const TimeErrorScene scene(name);
  RenderSettings best = kSupersampledReference;
  best.supersample = 24;
  const FiniteDifferenceSteps best_steps;
  const Tensor target = render_reference(scene, scene.target_points(), best);
  const Directions directions = random_directions(scene.points(), 8, 4, kSeed);
  const ReferenceDerivatives top =
      finite_difference_reference(scene, rendered_loss(scene, target, best), directions, best_steps);
  std::printf("baseline: FD at s=24, step %.2f px (%.1f s), 8 position and 4 colour directions\n\n",
              best_steps.position_px, top.seconds);
  std::printf("| candidate | positions: rel diff to baseline | colours: rel diff | h vs 2h spread | seconds |\n");
  std::printf("|---|---:|---:|---:|---:|\n");
  const std::pair<int, double> candidates[] = {{8, 0.25}, {8, 0.5}, {8, 1.0}, {16, 0.125},
                                               {16, 0.25}, {16, 0.5}, {16, 1.0}, {24, 0.5}};
  for (const auto& [ss, step] : candidates) {
    RenderSettings settings = best;
    settings.supersample = ss;
    FiniteDifferenceSteps steps = best_steps;
    steps.position_px = step;
    const ReferenceDerivatives r =
        finite_difference_reference(scene, rendered_loss(scene, target, settings), directions, steps);
    std::printf("| FD s=%d, step %.3g px | %.3g | %.3g | %.3g | %.1f |\n", ss, step,
                relative_l2(r.position, top.position), relative_l2(r.colour, top.colour),
                relative_l2(r.position_h, r.position_2h), r.seconds);
    std::fflush(stdout);
  }
  for (int ss : {1, 4, 16}) {
    const Gradients aa = gradients(scene, target, {DType::Float64, true, ss});
    const Gradients plain = gradients(scene, target, {DType::Float64, false, ss});
    const std::vector<double> pa = project(aa.position, directions.position),
                              pp = project(plain.position, directions.position);
    std::vector<double> half(pa.size());  // interior + half the antialias silhouette term
    for (std::size_t k = 0; k < pa.size(); ++k) half[k] = 0.5 * (pa[k] + pp[k]);
    std::printf("| analytic f64 aa s=%d | %.3g | %.3g | | |\n", ss, relative_l2(pa, top.position),
                relative_l2(project(aa.colour, directions.colour), top.colour));
    std::printf("| analytic f64 s=%d | %.3g | %.3g | | |\n", ss, relative_l2(pp, top.position),
                relative_l2(project(plain.colour, directions.colour), top.colour));
    std::printf("| (aa + no aa) / 2, s=%d | %.3g | | | |\n", ss, relative_l2(half, top.position));
    std::fflush(stdout);
  }
  return 0;
}

// How far soft rasterization's analytic gradient is from finite differences
// of its own loss (its image against the exact target), per sigma: separates
// the bias of grading a blurred image against the exact one from the
// roughness of the soft image itself (docs/time_error.md).
int run_soft_consistency(const std::string& name) {
  const TimeErrorScene scene(name);
  const Directions directions = random_directions(scene.points(), kPositionDirections, kColourDirections, kSeed);
  const Tensor target = exact_scene_image(scene, scene.target_points(), scene.colours()).image;
  std::printf("| soft sigma | step px | positions: analytic vs own FD | own h vs 2h spread | colours: analytic vs own FD |\n");
  std::printf("|---:|---:|---:|---:|---:|\n");
  for (double sigma : kSoftSigmas) {
    const RenderSettings settings{DType::Float64, false, 1, sigma};
    const Gradients g = gradients(scene, target, settings);
    for (double step : {kExactPositionStepPx, 0.25}) {
      const ReferenceDerivatives own =
          finite_difference_reference(scene, rendered_loss(scene, target, settings), directions, {step});
      std::printf("| %s | %.2g | %.3g | %.3g | %.3g |\n", sigma_text(sigma).c_str(), step,
                  relative_l2(project(g.position, directions.position), own.position),
                  relative_l2(own.position_h, own.position_2h),
                  relative_l2(project(g.colour, directions.colour), own.colour));
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  raster::remove_temporaries_on_signals();  // Ctrl-C leaves no partial output behind
  TimeErrorArgs args;
  try {
    args = parse_time_error_args(std::vector<std::string>(argv + 1, argv + argc));
    if (args.action == TimeErrorArgs::Action::Sweep) check_time_error_outputs(args);
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "time_error: %s\n(run time_error --help for usage)\n", e.what());
    return 2;
  }
  set_num_threads(kThreads);
  try {
    switch (args.action) {
      case TimeErrorArgs::Action::Help: std::fputs(time_error_usage().c_str(), stdout); return 0;
      case TimeErrorArgs::Action::Convergence: return run_convergence(args.scenes[0]);
      case TimeErrorArgs::Action::SoftConsistency: return run_soft_consistency(args.scenes[0]);
      case TimeErrorArgs::Action::Sweep: break;
    }
    return run_sweep(args.scenes, args.supersampled_reference, args.csv_path, args.png_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "time_error: %s\n", e.what());
    return 1;
  }
}
