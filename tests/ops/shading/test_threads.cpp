// The shading functions give bit-identical values and gradients on 1 and 2
// threads where a reduction runs: vertex_tangents' per-vertex sums
// (scatter_add), the sums of a broadcast light's or material's gradient over
// the pixels, and the SH matrix product.
#include <catch2/catch.hpp>

#include <functional>
#include <vector>

#include "raster/procedural.h"
#include "shading_cases.h"

using namespace gr;
using gr::testing::same_bits;
using gr::testing::shading::leaf;
using gr::testing::shading::unit_directions;
using gr::testing::shading::vec3;

namespace {

// Runs f on fresh leaves copied from `inputs` with `threads` threads: the
// value and every input's gradient (for the weights w of the output).
std::vector<Tensor> run(int threads, const std::vector<Tensor>& inputs,
                        const std::function<Tensor(const std::vector<Tensor>&)>& f) {
  set_num_threads(threads);
  std::vector<Tensor> leaves;
  for (const Tensor& t : inputs) leaves.push_back(leaf(t));
  const Tensor y = f(leaves);
  backward(y, Tensor::uniform(y.shape(), -1, 1, 99, y.dtype()));
  std::vector<Tensor> out = {y.detach()};
  for (const Tensor& t : leaves) out.push_back(t.grad());
  set_num_threads(0);
  return out;
}

void check_same_on_1_and_2_threads(const std::vector<Tensor>& inputs,
                                   const std::function<Tensor(const std::vector<Tensor>&)>& f) {
  const std::vector<Tensor> one = run(1, inputs, f), two = run(2, inputs, f);
  for (std::size_t i = 0; i < one.size(); ++i) {
    INFO("output " << i << " (0: value, then the inputs' gradients)");
    CHECK(same_bits(one[i], two[i]));
  }
}

}  // namespace

TEST_CASE("shading: vertex_tangents, a broadcast Cook-Torrance light and SH lighting are bit-identical on 1 and 2 "
          "threads",
          "[ops][shading][threads]") {
  const raster::Mesh sphere = raster::make_uv_sphere(96, 192);  // 18k vertices, 37k faces
  const Tensor triangles = sphere.triangles;
  check_same_on_1_and_2_threads({sphere.positions, sphere.uvs, sphere.normals}, [&](const std::vector<Tensor>& in) {
    return shading::vertex_tangents(in[0], in[1], triangles, in[2]);
  });
  const std::int64_t pixels = 200000;
  const Tensor n = unit_directions(pixels, 1);
  check_same_on_1_and_2_threads(
      {vec3(0.8, 0.5, 0.2), Tensor::full({1}, 0.3, DType::Float64), Tensor::full({1}, 0.4, DType::Float64), n,
       normalize(vec3(0.2, 0.9, 0.3)), normalize(vec3(-0.1, 0.3, 1))},
      [](const std::vector<Tensor>& in) { return shading::cook_torrance(in[0], in[1], in[2], in[3], in[4], in[5]); });
  check_same_on_1_and_2_threads({vec3(0.7, 0.6, 0.5), n, Tensor::uniform({9, 3}, -1, 1, 2, DType::Float64)},
                                [](const std::vector<Tensor>& in) { return shading::sh_diffuse(in[0], in[1], in[2]); });
}
