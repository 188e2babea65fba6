// The threading contract of the tape (autodiff/tape.h): a graph belongs to the
// thread that recorded it; leaves may be shared between threads.
#include <catch2/catch.hpp>

#include <thread>
#include <vector>

#include "ops/ops.h"

using namespace gr;

namespace {

// Runs f on a new thread and waits for it; an exception from f is rethrown here.
template <class F>
void on_new_thread(F f) {
  std::exception_ptr error;
  std::thread t([&] {
    try {
      f();
    } catch (...) {
      error = std::current_exception();
    }
  });
  t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace

TEST_CASE("tape threads: a graph recorded on one thread cannot be backpropagated on another",
          "[autodiff][tape][parallel][errors]") {
  Tensor w = Tensor::uniform({1000}, -1, 1, 5, DType::Float64).set_requires_grad();
  Tensor y, loss;
  on_new_thread([&] {
    y = w * w;
    loss = sum(y);
  });
  // A second fresh thread: its tape's generation equals the first one's, so
  // only the tape id tells them apart.
  on_new_thread([&] {
    CHECK_THROWS_AS(backward(loss), TapeError);
    CHECK_THROWS_WITH(backward(loss), Catch::Contains("another thread") && Catch::Contains("tape"));
    CHECK_THROWS_AS(y * w, TapeError);
    CHECK_THROWS_WITH(sum(y), Catch::Contains("sum: input 0"));
    CHECK(Tape::current().size() == 0);
    // Its values are fine as a constant.
    Tensor z = sum(y.detach() * w);
    backward(z);
  });
  CHECK_THROWS_AS(backward(loss), TapeError);  // nor on the main thread
  REQUIRE(w.grad().defined());
  CHECK(w.grad().to_vector() == (w * w).detach().to_vector());
  Tape::current().clear();
}

TEST_CASE("tape threads: tapes of different threads have different ids", "[autodiff][tape][parallel]") {
  std::uint64_t other = 0;
  on_new_thread([&] { other = Tape::current().id(); });
  CHECK(other != Tape::current().id());
}

TEST_CASE("tape threads: threads backpropagating into one shared leaf lose no contribution",
          "[autodiff][tape][parallel]") {
  // Each backward adds exactly 1 to every element (exact in float64 in any
  // order), so the result must be exactly threads * iterations everywhere.
  const int threads = 4, iterations = 100;
  Tensor w = Tensor::zeros({100000}, DType::Float64).set_requires_grad();
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&] {
      for (int i = 0; i < iterations; ++i) backward(sum(w + 1.0));
    });
  for (std::thread& t : pool) t.join();
  const std::vector<double> g = w.grad().to_vector();
  std::size_t wrong = 0;
  for (double v : g) wrong += v != threads * iterations;
  CHECK(wrong == 0);
}
