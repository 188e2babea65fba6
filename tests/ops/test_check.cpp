// The ops' argument checks (ops/check.h): each throws the matching gr::Error
// with "op: argument 'name' ...", so every op reports bad input the same way.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "ops/check.h"

using namespace gr;
using namespace gr::detail;

namespace {

// Requires f to throw E with a message containing each of `parts`.
template <class E, class F>
void require_error(F&& f, std::initializer_list<std::string> parts) {
  try {
    f();
    FAIL("no exception");
  } catch (const E& e) {
    const std::string msg = e.what();
    INFO("message: " << msg);
    for (const std::string& p : parts) CHECK(msg.find(p) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("op checks: dtype and definedness errors name the op and the argument", "[ops][check][errors]") {
  const Tensor f = Tensor::zeros({2, 4}), d = Tensor::zeros({2, 4}, DType::Float64);
  const Tensor i = Tensor::zeros({2, 3}, DType::Int32);
  require_error<ValueError>([&] { check_defined(Tensor(), "myop", "x"); }, {"myop: argument 'x'", "undefined"});
  require_error<DTypeError>([&] { check_float(i, "myop", "x"); }, {"myop: argument 'x'", "float32 or float64"});
  require_error<DTypeError>([&] { check_dtype(f, DType::Int32, "myop", "idx"); }, {"myop: argument 'idx'", "int32"});
  require_error<DTypeError>([&] { check_same_dtype(f, d, "myop", "a", "b"); }, {"myop: argument 'a'", "'b'"});
  CHECK_NOTHROW(check_float(d, "myop", "x"));
  CHECK_NOTHROW(check_same_dtype(d, d, "myop", "a", "b"));
}

TEST_CASE("op checks: shape errors state the expected shape and the tensor given", "[ops][check][errors]") {
  const Tensor t = Tensor::zeros({2, 4});
  require_error<ShapeError>([&] { check_shape(t, {2, 3}, "myop", "x"); }, {"myop: argument 'x'", "[2, 3]", "[2, 4]"});
  require_error<ShapeError>([&] { check_columns(t, 3, "myop", "tris", "M"); }, {"argument 'tris'", "[M, 3]"});
  CHECK_NOTHROW(check_shape(t, {2, 4}, "myop", "x"));
  CHECK_NOTHROW(check_columns(t, 4, "myop", "clip"));
}

TEST_CASE("op checks: value and index errors name the first bad element", "[ops][check][errors]") {
  Tensor clip = Tensor::zeros({3, 4}, DType::Float64);
  clip.data<double>()[6] = std::nan("");
  require_error<ValueError>([&] { check_finite(clip, "myop", "clip"); }, {"myop", "clip[6]", "NaN or Inf"});
  require_error<ValueError>([&] { check_image_size(0, 16, "myop"); }, {"myop", "image size 0 x 16"});
  require_error<ValueError>([&] { check_image_size(16384, 16385, "myop"); }, {"image size"});
  CHECK_NOTHROW(check_image_size(16384, 16384, "myop"));
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 2, 1, 3}, {2, 3});
  require_error<IndexError>([&] { check_triangles(tris, 3, "myop"); }, {"myop", "tris[1][2] = 3", "[0, 3)"});
  CHECK_NOTHROW(check_triangles(tris, 4, "myop"));
  const Tensor ids = Tensor::from_vector<std::int32_t>({0, 1, 2, 3}, {2, 2});
  require_error<IndexError>([&] { check_tri_ids(ids, 2, "myop"); }, {"myop", "tri_id[3] = 3"});
  CHECK_NOTHROW(check_tri_ids(ids, 3, "myop"));
}
