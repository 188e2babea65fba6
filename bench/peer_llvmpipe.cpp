// peer_llvmpipe: our rasterizer against Mesa llvmpipe (OSMesa) on the same
// clip-space float vertices, 1024 x 1024, producing the same G-buffer
// (tri_id, u, v, depth). One run interleaves both renderers repetition by
// repetition and prints medians, then a correctness cross-check of the two
// G-buffers. docs/peers.md explains the setup and the measured numbers.
//
//   peer_llvmpipe [--mesh FILE.obj] [--size 1024] [--reps 9] [--lp-threads 2]
//                 [--meshes name,name] [--ours-only] [--profile N]
//
// --profile N runs our kernel (2 threads) and the llvmpipe G-buffer draw (unless
// --ours-only) once uncounted, then N times each; under `valgrind
// --tool=callgrind --instr-atstart=no` only those calls are counted, and each
// renderer's calls are dumped as a separate part.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "examples/common/cli_args.h"
#include "ops/render/rasterize.h"
#include "peer_llvmpipe_compare.h"
#include "peer_llvmpipe_gl.h"
#include "peer_llvmpipe_scene.h"
#include "raster/rasterize.h"

#if defined(__has_include)
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#endif
#endif
#ifndef CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#define CALLGRIND_DUMP_STATS_AT(pos_str) ((void)(pos_str))
#endif

namespace {

struct Options {
  std::string mesh_path;
  int size = 1024;
  int reps = 9;
  int lp_threads = 2;
  std::string only;  // comma-separated scene names, empty = all
  bool ours_only = false;
  int profile = 0;  // > 0: only run our kernel this many times per mesh
};

Options parse(int argc, char** argv) {
  Options o;
  const char* usage =
      "usage: peer_llvmpipe [--mesh FILE.obj] [--size N] [--reps N] [--lp-threads N]\n"
      "                     [--meshes name,name] [--ours-only] [--profile N]\n";
  gr::cli::parse_flags_or_exit(
      "peer_llvmpipe", usage, argc, argv,
      {{"--mesh", "--size", "--reps", "--lp-threads", "--meshes", "--profile"}, {"--ours-only"}},
      [&](const std::string& flag, const std::string& v) {
        using gr::cli::parse_int;
        if (flag == "--mesh") o.mesh_path = v;
        else if (flag == "--size") o.size = parse_int(flag, v, 1, 16384);
        else if (flag == "--reps") o.reps = parse_int(flag, v, 1, 1000000);
        else if (flag == "--lp-threads") o.lp_threads = parse_int(flag, v, 1, 1024);
        else if (flag == "--meshes") o.only = v;
        else if (flag == "--ours-only") o.ours_only = true;
        else o.profile = parse_int(flag, v, 1, 1000000);
      });
  return o;
}

std::string load_average() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

template <class F>
double time_ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Our G-buffer in preallocated arrays (rasterize_forward writes every pixel).
struct OurBuffers {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv, depth;
  explicit OurBuffers(int size)
      : tri_id(std::size_t(size) * size), uv(std::size_t(size) * size * 2), depth(std::size_t(size) * size) {}
};

bool selected(const Options& o, const std::string& name) {
  if (o.only.empty()) return true;
  std::stringstream list(o.only);
  for (std::string item; std::getline(list, item, ',');)
    if (item == name) return true;
  return false;
}

struct Row {
  std::string name;
  std::int64_t triangles = 0, covered = 0;
  double k1 = NAN, k2 = NAN, op1 = NAN, op2 = NAN, gl = NAN, gl_id = NAN, gl_clear = NAN;
};

}  // namespace

int main(int argc, char** argv) {
  const Options opt = parse(argc, argv);
  const int size = opt.size;
  std::printf("peer_llvmpipe: %dx%d float32, %d repetitions (medians), load average at start %s\n",
              size, size, opt.reps, load_average().c_str());
  std::vector<std::string> notes;
  const std::vector<peer::Scene> scenes =
      peer::make_scenes(opt.mesh_path, [&](const std::string& name) { return selected(opt, name); }, &notes);
  for (const std::string& n : notes) std::printf("  %s\n", n.c_str());

  std::unique_ptr<peer::LlvmpipeRasterizer> gl;
  if (!opt.ours_only) {
    std::string error;
    gl = peer::LlvmpipeRasterizer::create(size, size, opt.lp_threads, &error);
    if (!gl) {
      std::fprintf(stderr, "llvmpipe unavailable: %s\n", error.c_str());
      return 1;
    }
    std::printf("  llvmpipe: %s, LP_NUM_THREADS=%d\n", gl->description().c_str(), opt.lp_threads);
  }
  gr::raster::RasterSettings settings;
  settings.width = size;
  settings.height = size;

  std::vector<Row> rows;
  for (const peer::Scene& scene : scenes) {
    const float* clip = scene.clip.data<float>();
    const std::int64_t nv = scene.clip.size(0), nt = scene.triangles.size(0);
    const std::int32_t* tris = scene.triangles.data<std::int32_t>();
    const gr::raster::RasterParams<float> params{clip, nv, tris, nt, settings};
    OurBuffers ours(size);
    auto run_kernel = [&](int threads) {
      gr::set_num_threads(threads);
      return time_ms([&] {
        gr::raster::rasterize_forward(params, ours.tri_id.data(), ours.uv.data(), ours.depth.data());
      });
    };
    auto run_op = [&](int threads) {
      gr::set_num_threads(threads);
      gr::NoGradGuard no_grad;
      gr::GBuffer gb;
      const double ms = time_ms([&] { gb = gr::rasterize(scene.clip, scene.triangles, {size, size}); });
      return ms;  // gb (and its buffers) released after timing
    };
    if (opt.profile) {
      // One uncounted warm-up each (scratch pools, JIT), then counted calls,
      // each renderer's calls dumped as its own part ("ours NAME", "llvmpipe NAME").
      run_kernel(2);
      gr::set_num_threads(2);
      for (int r = 0; r < opt.profile; ++r) {
        CALLGRIND_START_INSTRUMENTATION;
        const double ms = time_ms([&] {
          gr::raster::rasterize_forward(params, ours.tri_id.data(), ours.uv.data(), ours.depth.data());
        });
        CALLGRIND_STOP_INSTRUMENTATION;
        std::printf("  profile %s (%lld triangles): ours kernel 2 threads %.2f ms\n", scene.name.c_str(),
                    (long long)nt, ms);
      }
      CALLGRIND_DUMP_STATS_AT(("ours " + scene.name).c_str());
      if (gl) {
        gl->upload(clip, nv, tris, nt);
        gl->draw_gbuffer();
        for (int r = 0; r < opt.profile; ++r) {
          CALLGRIND_START_INSTRUMENTATION;
          const double ms = time_ms([&] { gl->draw_gbuffer(); });
          CALLGRIND_STOP_INSTRUMENTATION;
          std::printf("  profile %s: llvmpipe G-buffer %.2f ms\n", scene.name.c_str(), ms);
        }
        CALLGRIND_DUMP_STATS_AT(("llvmpipe " + scene.name).c_str());
      }
      continue;
    }
    if (gl) gl->upload(clip, nv, tris, nt);

    // Warm-up: one untimed run of everything (page faults, JIT, TBB pool).
    run_kernel(2);
    run_op(2);
    if (gl) {
      gl->draw_gbuffer();
      gl->draw_id_only();
    }
    std::vector<double> k1, k2, op1, op2, g, gid, gclear;
    for (int r = 0; r < opt.reps; ++r) {
      k1.push_back(run_kernel(1));
      op1.push_back(run_op(1));
      k2.push_back(run_kernel(2));
      op2.push_back(run_op(2));
      if (gl) {
        g.push_back(time_ms([&] { gl->draw_gbuffer(); }));
        gid.push_back(time_ms([&] { gl->draw_id_only(); }));
        gclear.push_back(time_ms([&] { gl->clear_only(); }));
      }
    }
    gr::set_num_threads(0);

    Row row;
    row.name = scene.name;
    row.triangles = nt;
    run_kernel(2);
    row.covered = std::count_if(ours.tri_id.begin(), ours.tri_id.end(), [](std::int32_t id) { return id != 0; });
    row.k1 = median(k1);
    row.k2 = median(k2);
    row.op1 = median(op1);
    row.op2 = median(op2);
    if (gl) {
      row.gl = median(g);
      row.gl_id = median(gid);
      row.gl_clear = median(gclear);
      const peer::GBufferView mine{ours.tri_id.data(), ours.uv.data(), ours.depth.data()};
      gl->draw_gbuffer();
      const peer::GlGBuffer full = gl->read_back();
      const peer::Agreement a = peer::compare_gbuffers(clip, tris, size, size, mine,
                                                       {full.tri_id.data(), full.uv.data(), full.depth.data()});
      gl->draw_id_only();
      const peer::GlGBuffer ids = gl->read_back();
      const peer::Agreement b = peer::compare_gbuffers(clip, tris, size, size, mine,
                                                       {ids.tri_id.data(), nullptr, ids.depth.data()});
      std::printf(
          "  check %s: tri_id equal on %.4f%% of %lld pixels covered by either "
          "(only ours %lld, only llvmpipe %lld, different id %lld)\n"
          "    disagreements: %lld within %.4f px of an edge, %lld inside both triangles "
          "(max exact depth gap %.2e), %lld outside a triangle\n"
          "    equal ids: max |du| %.2e, max |dv| %.2e (mean %.2e, %.2e), max |ddepth| %.2e; "
          "id-only indexed pass: tri_id equal on %.4f%%\n",
          scene.name.c_str(), 100.0 * a.same_id / std::max<std::int64_t>(1, a.either_covered),
          (long long)a.either_covered, (long long)a.only_a, (long long)a.only_b, (long long)a.different_id,
          (long long)a.disagree_at_edge, peer::kEdgeTolerance, (long long)a.disagree_inside,
          a.max_depth_gap_inside, (long long)a.disagree_outside, a.max_du, a.max_dv, a.mean_du, a.mean_dv,
          a.max_ddepth, 100.0 * b.same_id / std::max<std::int64_t>(1, b.either_covered));
    }
    rows.push_back(row);
    std::fflush(stdout);
  }

  if (opt.profile) return 0;
  std::printf("\n| mesh | triangles | covered px | ours kernel 1 thr ms | ours kernel 2 thr ms "
              "| ours op 1 thr ms | ours op 2 thr ms | llvmpipe G-buffer ms (%d thr) | ratio ours 2 thr / llvmpipe "
              "| llvmpipe id-only indexed ms | llvmpipe clear ms |\n",
              opt.lp_threads);
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows)
    std::printf("| %s | %lld | %lld | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |\n", r.name.c_str(),
                (long long)r.triangles, (long long)r.covered, r.k1, r.k2, r.op1, r.op2, r.gl, r.k2 / r.gl,
                r.gl_id, r.gl_clear);
  std::printf("load average at end %s\n", load_average().c_str());
  return 0;
}
