// vertex_normals, forward and forward + backward, against the composite of
// tensor ops it was until session 25 (gathers of the corners, cross,
// scatter_add of the three corner columns, normalize): the fit example calls
// it once per iteration on a 2562-point sphere (issue 31).
//   Args {icosphere subdivisions, backward (0/1), threads (set_num_threads)}.
// Measured: docs/performance.md, "Vertex normals as one op, and map_rows' trace block".
#include <benchmark/benchmark.h>

#include <functional>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "raster/procedural.h"

namespace {

using namespace gr;

Tensor composite_normals(const Tensor& p, const Tensor& t) {
  auto corner = [&](int k) { return reshape(slice(t, 1, k, k + 1), {t.size(0)}); };
  const Tensor i0 = corner(0), i1 = corner(1), i2 = corner(2);
  const Tensor p0 = gather(p, i0);
  const Tensor face = cross(gather(p, i1) - p0, gather(p, i2) - p0);
  return normalize(scatter_add(concat({face, face, face}, 0), concat({i0, i1, i2}, 0), p.size(0)));
}

void time_normals(benchmark::State& state, Tensor (*normals)(const Tensor&, const Tensor&)) {
  const raster::Mesh mesh = raster::make_icosphere(static_cast<int>(state.range(0)));
  const bool with_backward = state.range(1) != 0;
  set_num_threads(static_cast<int>(state.range(2)));
  const Tensor positions = mesh.positions.copy().set_requires_grad(with_backward);
  const Tensor upstream = Tensor::uniform(positions.shape(), -1, 1, 7, positions.dtype());
  for (auto _ : state) {
    Tensor out = normals(positions, mesh.triangles);
    if (with_backward)
      backward(out, upstream);
    else
      Tape::current().clear();
    benchmark::DoNotOptimize(out.data<float>());
  }
  set_num_threads(0);
}

void BM_VertexNormals(benchmark::State& state) {
  time_normals(state, [](const Tensor& p, const Tensor& t) { return vertex_normals(p, t); });
}
void BM_VertexNormalsComposite(benchmark::State& state) { time_normals(state, composite_normals); }

void Args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"subdivisions", "backward", "threads"})->Unit(benchmark::kMicrosecond)->UseRealTime();
  for (int subdivisions : {4, 7})
    for (int backward : {0, 1})
      for (int threads : {1, 2}) b->Args({subdivisions, backward, threads});
}

BENCHMARK(BM_VertexNormals)->Apply(Args);
BENCHMARK(BM_VertexNormalsComposite)->Apply(Args);

}  // namespace

BENCHMARK_MAIN();
