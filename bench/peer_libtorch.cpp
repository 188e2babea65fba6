// peer_libtorch (issue 6, items 2 and 5): the Blinn-Phong shading graph of
// bench/shading_graph.h (forward and forward+backward, float32) in gradraster
// and, on a copy of the same input values, in libtorch's C++ API on CPU.
//
// Prints, from one run:
//   - peak RSS of each side, each measured in its own child process;
//   - how far the two sides' gradients are apart;
//   - median times of forward and forward+backward at 2 and 1 threads, taken
//     interleaved (ours, torch, ours, ... with the thread count alternating
//     too), and the ratios the issue asks about;
//   - our storage cache's fresh allocations after the first iteration.
//
//   peer_libtorch [--pixels N] [--reps R] [--rss-iterations K]
//   peer_libtorch --profile-ours K [--pixels N]   (ours only, for perf/callgrind)
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "examples/common/cli_args.h"
#include "peer_libtorch_graph.h"
#include "peer_libtorch_rss.h"

namespace {

using gr::bench::ShadingScene;
using gr::bench::TorchShadingScene;

struct Options {
  std::int64_t pixels = 1 << 20;
  int reps = 11;           // timed repetitions per configuration (median taken)
  int rss_iterations = 5;  // forward+backward iterations run by each peak-RSS child
  int profile_ours = 0;    // > 0: run only our forward+backward this many times
};

Options parse(int argc, char** argv) {
  Options o;
  const char* usage =
      "usage: peer_libtorch [--pixels N] [--reps R] [--rss-iterations K]\n"
      "       peer_libtorch --profile-ours K [--pixels N]   (ours only, for perf/callgrind)\n";
  gr::cli::parse_flags_or_exit(
      "peer_libtorch", usage, argc, argv, {{"--pixels", "--reps", "--rss-iterations", "--profile-ours"}, {}},
      [&](const std::string& flag, const std::string& v) {
        if (flag == "--pixels") o.pixels = gr::cli::parse_integer(flag, v, 1, std::int64_t(1) << 30);
        else if (flag == "--reps") o.reps = gr::cli::parse_int(flag, v, 1, 1000000);
        else if (flag == "--rss-iterations") o.rss_iterations = gr::cli::parse_int(flag, v, 1, 1000000);
        else o.profile_ours = gr::cli::parse_int(flag, v, 1, 1000000);
      });
  return o;
}

void set_threads(int n) {
  gr::set_num_threads(n);
  torch::set_num_threads(n);
}

// One iteration of each side. Gradients are reset (to "none") before, not
// after, the backward pass so that they stay readable afterwards.
double ours_forward(const ShadingScene& s) {
  gr::NoGradGuard no_grad;
  return gr::bench::blinn_phong_loss(s).item();
}

double ours_forward_backward(ShadingScene& s) {
  s.n.zero_grad();
  s.albedo.zero_grad();
  s.light.zero_grad();
  gr::Tensor loss = gr::bench::blinn_phong_loss(s);
  gr::backward(loss);
  return loss.item();
}

double torch_forward(const TorchShadingScene& s) {
  torch::NoGradGuard no_grad;
  return gr::bench::torch_blinn_phong_loss(s).item<float>();
}

double torch_forward_backward(TorchShadingScene& s) {
  s.n.mutable_grad().reset();
  s.albedo.mutable_grad().reset();
  s.light.mutable_grad().reset();
  torch::Tensor loss = gr::bench::torch_blinn_phong_loss(s);
  loss.backward();
  return loss.item<float>();
}

template <class F>
double time_ms(F f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// Worst element of |a - b| / max(|a|, |b|, 1e-3 * max|b|): relative, with a
// floor (as in gr::gradcheck) so that near-zero entries are judged against
// the gradient's scale instead of themselves.
struct GradDiff {
  double max_rel = 0;
  double max_abs = 0;
  double scale = 0;  // max |torch gradient|
};

GradDiff compare(const gr::Tensor& ours, const torch::Tensor& theirs) {
  const float* a = ours.data<float>();
  const torch::Tensor c = theirs.contiguous();
  const float* b = c.data_ptr<float>();
  const std::int64_t n = ours.numel();
  GradDiff d;
  for (std::int64_t i = 0; i < n; ++i) d.scale = std::max(d.scale, std::fabs(double(b[i])));
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = a[i], y = b[i], diff = std::fabs(x - y);
    d.max_abs = std::max(d.max_abs, diff);
    d.max_rel = std::max(d.max_rel, diff / std::max({std::fabs(x), std::fabs(y), 1e-3 * d.scale, 1e-30}));
  }
  return d;
}

bool bit_identical(const gr::Tensor& a, const gr::Tensor& b) {
  return std::memcmp(a.data<float>(), b.data<float>(), sizeof(float) * static_cast<std::size_t>(a.numel())) == 0;
}

long vm_hwm_kib() {  // this process's peak RSS so far (/proc/self/status VmHWM)
  FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return -1;
  char line[256];
  long kib = -1;
  while (std::fgets(line, sizeof line, f))
    if (std::strncmp(line, "VmHWM:", 6) == 0) kib = std::atol(line + 6);
  std::fclose(f);
  return kib;
}

// --- peak RSS, each side in its own child process ---------------------------

void measure_peak_rss(const Options& o) {
  const long base = gr::bench::child_peak_rss_kib([] {});
  const long ours = gr::bench::child_peak_rss_kib([&] {
    gr::set_num_threads(2);
    ShadingScene s = gr::bench::make_shading_scene(o.pixels, gr::DType::Float32);
    for (int i = 0; i < o.rss_iterations; ++i) ours_forward_backward(s);
  });
  long torch_setup = -1;
  int pipe_fd[2];
  if (pipe(pipe_fd) != 0) throw std::runtime_error("pipe failed");
  const long theirs = gr::bench::child_peak_rss_kib([&] {
    close(pipe_fd[0]);
    TorchShadingScene t;
    {
      // The inputs are built by gradraster (1 thread, no pool) and copied;
      // the gradraster copies are then freed before torch's loop starts.
      gr::set_num_threads(1);
      ShadingScene s = gr::bench::make_shading_scene(o.pixels, gr::DType::Float32);
      t = gr::bench::torch_copy_of(s);
    }
    gr::release_cached_storage();
    malloc_trim(0);
    const long setup = vm_hwm_kib();
    if (write(pipe_fd[1], &setup, sizeof setup) != sizeof setup) std::perror("write");
    close(pipe_fd[1]);
    torch::set_num_threads(2);
    for (int i = 0; i < o.rss_iterations; ++i) torch_forward_backward(t);
  });
  close(pipe_fd[1]);
  if (read(pipe_fd[0], &torch_setup, sizeof torch_setup) != sizeof torch_setup) torch_setup = -1;
  close(pipe_fd[0]);

  const double mib = 1024.0;
  std::printf("Peak RSS (ru_maxrss of a child process via wait4; %d forward+backward iterations, 2 threads)\n",
              o.rss_iterations);
  std::printf("  process image only (same binary, does nothing)  %8.1f MiB\n", base / mib);
  std::printf("  ours   (gradraster)                             %8.1f MiB\n", ours / mib);
  std::printf("  torch  (libtorch)                               %8.1f MiB   (its peak while building the inputs: %.1f MiB)\n",
              theirs / mib, torch_setup / mib);
  std::printf("  ratio ours / torch                              %8.2f   (target <= 0.5)\n", double(ours) / theirs);
  std::printf("  Nothing subtracted: each figure includes the process image (the binary links both\n"
              "  libraries), the inputs, gradients, intermediates and, for ours, the storage cache's\n"
              "  retained buffers; thread stacks of each side's pool.\n\n");
}

// --- timings -----------------------------------------------------------------

struct Times {
  std::vector<double> ours_fwd, ours_fb, torch_fwd, torch_fb;
};

void print_times(int threads, const Times& t) {
  const double of = median(t.ours_fwd), ob = median(t.ours_fb);
  const double tf = median(t.torch_fwd), tb = median(t.torch_fb);
  std::printf("%d thread%s (medians of %zu)\n", threads, threads == 1 ? "" : "s", t.ours_fwd.size());
  std::printf("  %-8s fwd %8.2f ms   fwd+bwd %8.2f ms   bwd/fwd %5.2f   (fwd+bwd)/fwd %5.2f\n", "ours", of, ob,
              (ob - of) / of, ob / of);
  std::printf("  %-8s fwd %8.2f ms   fwd+bwd %8.2f ms   bwd/fwd %5.2f   (fwd+bwd)/fwd %5.2f\n", "torch", tf, tb,
              (tb - tf) / tf, tb / tf);
  std::printf("  ratio ours/torch: fwd %.2f, fwd+bwd %.2f (target <= 0.5)\n", of / tf, ob / tb);
}

int profile_ours(const Options& o) {
  set_threads(2);
  ShadingScene s = gr::bench::make_shading_scene(o.pixels, gr::DType::Float32);
  double loss = 0;
  for (int i = 0; i < o.profile_ours; ++i) loss = ours_forward_backward(s);
  std::printf("ours: %d forward+backward iterations on %lld pixels, loss %.9g\n", o.profile_ours,
              static_cast<long long>(o.pixels), loss);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  if (o.profile_ours > 0) return profile_ours(o);
  std::printf("Blinn-Phong shading graph, %lld pixels, float32: gradraster vs libtorch %s (CPU)\n\n",
              static_cast<long long>(o.pixels), TORCH_VERSION);

  // Before anything else: the children must not inherit big buffers or thread pools.
  measure_peak_rss(o);

  ShadingScene ours = gr::bench::make_shading_scene(o.pixels, gr::DType::Float32);
  TorchShadingScene theirs = gr::bench::torch_copy_of(ours);

  // Gradients of both sides (2 threads), and ours again at 1 thread.
  set_threads(2);
  const double ours_loss = ours_forward_backward(ours);
  const double torch_loss = torch_forward_backward(theirs);
  const gr::Tensor g2[3] = {ours.n.grad(), ours.albedo.grad(), ours.light.grad()};
  std::printf("Loss: ours %.9g, torch %.9g (relative difference %.2e)\n", ours_loss, torch_loss,
              std::fabs(ours_loss - torch_loss) / std::fabs(torch_loss));
  std::printf("Gradient agreement, max over elements of |ours - torch| / max(|ours|, |torch|, 1e-3 max|torch|):\n");
  const char* names[3] = {"n", "albedo", "light"};
  const torch::Tensor tg[3] = {theirs.n.grad(), theirs.albedo.grad(), theirs.light.grad()};
  for (int k = 0; k < 3; ++k) {
    const GradDiff d = compare(g2[k], tg[k]);
    std::printf("  d loss / d %-7s max rel %.2e   max abs %.2e   (max |grad| %.2e)\n", names[k], d.max_rel, d.max_abs,
                d.scale);
  }
  set_threads(1);
  ours_forward_backward(ours);
  const bool same = bit_identical(g2[0], ours.n.grad()) && bit_identical(g2[1], ours.albedo.grad()) &&
                    bit_identical(g2[2], ours.light.grad());
  std::printf("Our gradients at 1 and 2 threads bit-identical: %s\n\n", same ? "yes" : "NO");

  // Warm-up (both thread counts), then the interleaved timed run.
  const int thread_counts[2] = {2, 1};
  for (int threads : thread_counts) {
    set_threads(threads);
    for (int i = 0; i < 2; ++i) {
      ours_forward(ours);
      torch_forward(theirs);
      ours_forward_backward(ours);
      torch_forward_backward(theirs);
    }
  }
  const gr::StorageStats before = gr::storage_stats();
  Times times[2];
  for (int rep = 0; rep < o.reps; ++rep) {
    for (int c = 0; c < 2; ++c) {
      set_threads(thread_counts[c]);
      Times& t = times[c];
      const bool ours_first = (rep + c) % 2 == 0;  // alternate who goes first
      for (int side = 0; side < 2; ++side) {
        if ((side == 0) == ours_first) t.ours_fwd.push_back(time_ms([&] { ours_forward(ours); }));
        else t.torch_fwd.push_back(time_ms([&] { torch_forward(theirs); }));
      }
      for (int side = 0; side < 2; ++side) {
        if ((side == 0) == ours_first) t.ours_fb.push_back(time_ms([&] { ours_forward_backward(ours); }));
        else t.torch_fb.push_back(time_ms([&] { torch_forward_backward(theirs); }));
      }
    }
  }
  const gr::StorageStats after = gr::storage_stats();

  std::printf("Times (wall clock, steady_clock; interleaved ours/torch and 2/1 threads; 2 warm-up rounds)\n");
  std::printf("  bwd/fwd = (fwd+bwd - fwd) / fwd, fwd timed without gradient recording on both sides\n");
  for (int c = 0; c < 2; ++c) print_times(thread_counts[c], times[c]);
  const double s_fb = median(times[1].ours_fb) / median(times[0].ours_fb);
  const double s_f = median(times[1].ours_fwd) / median(times[0].ours_fwd);
  const double t_fb = median(times[1].torch_fb) / median(times[0].torch_fb);
  std::printf("Speed-up 1 -> 2 threads: ours fwd+bwd %.2fx, fwd %.2fx (target >= 1.8); torch fwd+bwd %.2fx\n\n", s_fb,
              s_f, t_fb);

  std::printf("Our storage cache over the %d timed rounds (iteration 1 and the warm-up excluded: 6 fwd+bwd, 4 fwd):\n",
              o.reps);
  std::printf("  fresh allocations %lld (should be 0), buffers reused %lld, cached now %.1f MiB\n",
              static_cast<long long>(after.fresh_allocations - before.fresh_allocations),
              static_cast<long long>(after.reused - before.reused), after.cached_bytes / (1024.0 * 1024.0));
  return 0;
}
