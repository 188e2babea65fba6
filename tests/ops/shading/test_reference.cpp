// The shading functions against an independent evaluation of the published
// formulas: tests/data/shading_reference/shading_reference.txt, written by
// make_shading_reference.py there (plain Python floats, one scalar formula
// per component; format in its README.md). Every row is checked in float64 to
// 1e-12 relative (1e-15 absolute near zero); the Python tests read the same file.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "shading_cases.h"

using namespace gr;

namespace {

using Values = std::vector<double>;

// Inputs [begin, begin + n) as a float64 tensor of shape [n].
Tensor part(const Values& in, std::size_t begin, std::size_t n) {
  return gr::testing::shading::vec(Values(in.begin() + static_cast<std::ptrdiff_t>(begin),
                                          in.begin() + static_cast<std::ptrdiff_t>(begin + n)));
}

struct Function {
  std::size_t inputs, outputs;
  std::function<Values(const Values&)> evaluate;
};

// Each function of the table with its arity (README.md) and its evaluation by gr::shading.
const std::map<std::string, Function>& functions() {
  static const std::map<std::string, Function> table = {
      {"srgb_to_linear", {1, 1, [](const Values& x) { return shading::srgb_to_linear(part(x, 0, 1)).to_vector(); }}},
      {"linear_to_srgb", {1, 1, [](const Values& x) { return shading::linear_to_srgb(part(x, 0, 1)).to_vector(); }}},
      {"lambert",
       {9, 3, [](const Values& x) { return shading::lambert(part(x, 0, 3), part(x, 3, 3), part(x, 6, 3)).to_vector(); }}},
      {"blinn_phong",
       {16, 3,
        [](const Values& x) {
          return shading::blinn_phong(part(x, 0, 3), part(x, 3, 3), part(x, 6, 1), part(x, 7, 3), part(x, 10, 3),
                                      part(x, 13, 3))
              .to_vector();
        }}},
      {"ggx_distribution",
       {2, 1, [](const Values& x) { return shading::ggx_distribution(part(x, 0, 1), part(x, 1, 1)).to_vector(); }}},
      {"smith_ggx_correlated",
       {3, 1,
        [](const Values& x) {
          return shading::smith_ggx_correlated(part(x, 0, 1), part(x, 1, 1), part(x, 2, 1)).to_vector();
        }}},
      {"fresnel_schlick",
       {4, 3, [](const Values& x) { return shading::fresnel_schlick(part(x, 0, 1), part(x, 1, 3)).to_vector(); }}},
      {"cook_torrance",
       {14, 3,
        [](const Values& x) {
          return shading::cook_torrance(part(x, 0, 3), part(x, 3, 1), part(x, 4, 1), part(x, 5, 3), part(x, 8, 3),
                                        part(x, 11, 3))
              .to_vector();
        }}},
      {"point_light",
       {9, 6,
        [](const Values& x) {
          const shading::LightSample s = shading::point_light(part(x, 0, 3), part(x, 3, 3), part(x, 6, 3));
          return concat({s.direction, s.radiance}, 0).to_vector();
        }}},
      {"sh_basis", {3, 9, [](const Values& x) { return shading::sh_basis(part(x, 0, 3)).to_vector(); }}},
      {"sh_irradiance",
       {30, 3,
        [](const Values& x) {
          return shading::sh_irradiance(part(x, 0, 3), reshape(part(x, 3, 27), {9, 3})).to_vector();
        }}},
      {"perturb_normal",
       {10, 3,
        [](const Values& x) { return shading::perturb_normal(part(x, 0, 3), part(x, 3, 4), part(x, 7, 3)).to_vector(); }}},
  };
  return table;
}

}  // namespace

TEST_CASE("shading: every row of the independent reference table is reproduced to 1e-12 in float64",
          "[ops][shading][reference]") {
  const std::string path = std::string(GRADRASTER_TESTS_DIR) + "/data/shading_reference/shading_reference.txt";
  std::ifstream file(path);
  REQUIRE(file.good());
  std::map<std::string, int> rows_per_function;
  std::string line;
  int rows = 0;
  while (std::getline(file, line)) {
    if (line.empty()) continue;
    ++rows;
    std::istringstream fields(line);
    std::string name;
    fields >> name;
    Values numbers;
    for (double v; fields >> v;) numbers.push_back(v);
    INFO("row " << rows << ": " << line);
    REQUIRE(fields.eof());  // every field after the name parsed as a number
    const auto f = functions().find(name);
    REQUIRE(f != functions().end());
    REQUIRE(numbers.size() == f->second.inputs + f->second.outputs);
    ++rows_per_function[name];
    const Values inputs(numbers.begin(), numbers.begin() + static_cast<std::ptrdiff_t>(f->second.inputs));
    const Values expected(numbers.begin() + static_cast<std::ptrdiff_t>(f->second.inputs), numbers.end());
    const Values got = f->second.evaluate(inputs);
    REQUIRE(got.size() == expected.size());
    for (std::size_t k = 0; k < got.size(); ++k) {
      INFO("output " << k << ": got " << got[k] << ", expected " << expected[k]);
      CHECK(std::abs(got[k] - expected[k]) <= 1e-12 * std::abs(expected[k]) + 1e-15);
    }
  }
  CHECK(rows == 75);
  CHECK(rows_per_function.size() == functions().size());  // every function has rows
}
