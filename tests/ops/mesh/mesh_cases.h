// Meshes for the mesh-op tests: the reference meshes of
// tests/data/mesh_losses/reference.txt (with Python's values and gradients,
// written by tests/data/mesh_losses/generate.py) and random icospheres.
#pragma once

#include <catch2/catch.hpp>

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

namespace gr::testing {

struct ReferenceMesh {
  std::string name;
  Tensor positions;  // float64 [V, 3]
  Tensor triangles;  // int32 [F, 3]
  std::map<std::string, std::vector<double>> values;
  const std::vector<double>& value(const std::string& key) const {
    const auto it = values.find(key);
    if (it == values.end()) FAIL("reference.txt has no value '" << key << "' for mesh " << name);
    return it->second;
  }
};

// The meshes 'icosphere', 'hard' and 'zero_area' (see generate.py), parsed once.
inline const std::vector<ReferenceMesh>& reference_meshes() {
  static const std::vector<ReferenceMesh> meshes = [] {
    const std::string path = std::string(GRADRASTER_TESTS_DIR) + "/data/mesh_losses/reference.txt";
    std::ifstream in(path);
    if (!in) FAIL("cannot read " << path);
    std::vector<ReferenceMesh> out;
    std::vector<double> v;
    std::vector<std::int32_t> f;
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream s(line);
      std::string word;
      s >> word;
      if (word == "mesh") {
        out.emplace_back();
        s >> out.back().name;
        v.clear();
        f.clear();
      } else if (word == "v") {
        for (double x; s >> x;) v.push_back(x);
      } else if (word == "f") {
        for (std::int32_t x; s >> x;) f.push_back(x);
      } else if (word == "value") {
        const std::size_t bar = line.find(" | ");
        const std::string key = line.substr(6, bar - 6);
        std::istringstream rest(line.substr(bar + 3));
        std::size_t n = 0;
        rest >> n;
        std::vector<double> values(n);
        for (double& x : values) rest >> x;
        if (!rest) FAIL("reference.txt: value '" << key << "' is short");
        out.back().values[key] = values;
      } else if (word == "end") {
        out.back().positions = Tensor::from_vector(v, {std::int64_t(v.size() / 3), 3});
        out.back().triangles = Tensor::from_vector(f, {std::int64_t(f.size() / 3), 3});
      }
    }
    return out;
  }();
  return meshes;
}

inline const ReferenceMesh& reference_mesh(const std::string& name) {
  for (const auto& m : reference_meshes())
    if (m.name == name) return m;
  FAIL("reference.txt has no mesh " << name);
  throw 0;
}

// An icosphere (20 4^subdivisions faces) with every point moved by up to
// `amount` at random in each coordinate, as a float64 (or dtype) constant.
inline Tensor bumpy_icosphere_positions(const raster::Mesh& mesh, double amount, std::uint64_t seed,
                                        DType dtype = DType::Float64) {
  NoGradGuard no_grad;
  return (cast(mesh.positions, dtype) + Tensor::uniform({mesh.num_vertices(), 3}, -amount, amount, seed, dtype))
      .copy();
}

// positions with requires_grad set on a copy (a gradcheck input).
inline Tensor grad_input(const Tensor& positions) { return positions.detach().copy().set_requires_grad(); }

// run() gives a value and a gradient (a pair of tensors): the same bits with
// 2 and 8 threads as with 1.
template <class Run>
void check_same_bits_for_any_thread_count(const Run& run) {
  auto with_threads = [&](int threads) {
    set_num_threads(threads);
    auto result = run();
    set_num_threads(0);
    return result;
  };
  const auto reference = with_threads(1);
  for (int threads : {2, 8}) {
    INFO(threads << " threads");
    const auto result = with_threads(threads);
    CHECK(same_bits(reference.first, result.first));
    CHECK(same_bits(reference.second, result.second));
  }
}

}  // namespace gr::testing
