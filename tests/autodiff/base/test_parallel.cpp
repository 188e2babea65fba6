// parallel_for and the thread count: set_num_threads(n) really runs n threads
// (also more than the machine's cores), nested loops work, and errors thrown
// in a body reach the caller.
#include <catch2/catch.hpp>

#include <atomic>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/ops.h"

using namespace gr;

namespace {

// Sets the thread count for one test and restores the default after it.
struct ThreadCount {
  explicit ThreadCount(int n) { set_num_threads(n); }
  ~ThreadCount() { set_num_threads(0); }
};

// Distinct threads that ran the body of a parallel_for over `chunks` chunks of
// one element, each busy long enough for idle threads to steal work.
std::size_t distinct_threads(std::int64_t chunks, std::chrono::microseconds busy) {
  std::mutex m;
  std::set<std::thread::id> ids;
  parallel_for(0, chunks, 1, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      {
        std::lock_guard<std::mutex> lock(m);
        ids.insert(std::this_thread::get_id());
      }
      std::this_thread::sleep_for(busy);
    }
  });
  return ids.size();
}

}  // namespace

TEST_CASE("parallel: num_threads reports the count that was set", "[autodiff][parallel]") {
  for (int n : {1, 2, 3, 8, 16}) {
    ThreadCount count(n);
    CHECK(num_threads() == n);
  }
  set_num_threads(0);
  CHECK(num_threads() >= 1);
}

TEST_CASE("parallel: a negative or absurd thread count is refused and changes nothing", "[autodiff][parallel][errors]") {
  ThreadCount count(3);
  CHECK_THROWS_AS(set_num_threads(-3), ValueError);
  CHECK_THROWS_WITH(set_num_threads(-3), Catch::Contains("set_num_threads") && Catch::Contains("-3"));
  CHECK_THROWS_AS(set_num_threads(kMaxThreads + 1), ValueError);
  CHECK(num_threads() == 3);
}

TEST_CASE("parallel: 8 threads run on 8 threads even with fewer cores", "[autodiff][parallel]") {
  ThreadCount count(8);
  const std::size_t seen = distinct_threads(800, std::chrono::microseconds(500));
  INFO("distinct threads: " << seen << ", hardware threads: " << std::thread::hardware_concurrency());
  CHECK(seen > 2);
  CHECK(seen <= 8);
}

TEST_CASE("parallel: the thread count is an upper bound", "[autodiff][parallel]") {
  SECTION("one thread runs everything on the calling thread") {
    ThreadCount count(1);
    const std::thread::id me = std::this_thread::get_id();
    std::atomic<int> elsewhere{0};
    parallel_for(0, 100000, 16, [&](std::int64_t, std::int64_t) {
      if (std::this_thread::get_id() != me) ++elsewhere;
    });
    CHECK(elsewhere == 0);
  }
  SECTION("two and three threads") {
    for (int n : {2, 3}) {
      ThreadCount count(n);
      CHECK(distinct_threads(200, std::chrono::microseconds(200)) <= static_cast<std::size_t>(n));
    }
  }
}

TEST_CASE("parallel: every index is visited once, also by nested loops", "[autodiff][parallel]") {
  const std::int64_t rows = 64, cols = 5000;
  for (int n : {1, 2, 8, 0}) {
    ThreadCount count(n);
    std::vector<std::atomic<int>> hits(static_cast<std::size_t>(rows * cols));
    std::mutex m;
    std::set<std::thread::id> ids;
    parallel_for(0, rows, 1, [&](std::int64_t r0, std::int64_t r1) {
      for (std::int64_t r = r0; r < r1; ++r)
        parallel_for(0, cols, 64, [&](std::int64_t c0, std::int64_t c1) {
          {
            std::lock_guard<std::mutex> lock(m);
            ids.insert(std::this_thread::get_id());
          }
          for (std::int64_t c = c0; c < c1; ++c) ++hits[static_cast<std::size_t>(r * cols + c)];
        });
    });
    int wrong = 0;
    for (const auto& h : hits) wrong += h.load() != 1;
    INFO("threads " << n);
    CHECK(wrong == 0);
    // The inner loops share the outer loop's threads.
    CHECK(ids.size() <= static_cast<std::size_t>(num_threads()));
  }
}

TEST_CASE("parallel: an error thrown in a body reaches the caller", "[autodiff][parallel]") {
  for (int n : {1, 2, 8}) {
    ThreadCount count(n);
    CHECK_THROWS_AS(parallel_for(0, 100000, 100,
                                 [](std::int64_t lo, std::int64_t hi) {
                                   if (lo <= 54321 && 54321 < hi) throw ValueError("body: index 54321");
                                 }),
                    ValueError);
    // Still fully usable afterwards.
    std::atomic<std::int64_t> total{0};
    parallel_for(0, 100000, 100, [&](std::int64_t lo, std::int64_t hi) { total += hi - lo; });
    CHECK(total == 100000);
  }
}

TEST_CASE("parallel: deterministic_sum is bit-identical for 1, 2, 3, 8 and all threads",
          "[autodiff][parallel][determinism]") {
  std::vector<float> x(1 << 20);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = static_cast<float>(std::sin(0.37 * i)) * 1e3f + 1e-3f * i;
  auto sum = [&] {
    return deterministic_sum<double>(static_cast<std::int64_t>(x.size()), 4096, [&](std::int64_t lo, std::int64_t hi) {
      double s = 0;
      for (std::int64_t i = lo; i < hi; ++i) s += x[static_cast<std::size_t>(i)];
      return s;
    });
  };
  std::vector<double> sums;
  for (int n : {1, 2, 3, 8, 0}) {
    ThreadCount count(n);
    sums.push_back(sum());
  }
  for (double s : sums) CHECK(s == sums[0]);
}

TEST_CASE("parallel: changing the thread count while another thread runs loops is safe",
          "[autodiff][parallel]") {
  std::atomic<bool> stop{false};
  std::atomic<int> bad{0};
  std::thread worker([&] {
    std::vector<int> out(50000);
    while (!stop) {
      parallel_for(0, static_cast<std::int64_t>(out.size()), 256, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t i = lo; i < hi; ++i) out[static_cast<std::size_t>(i)] = static_cast<int>(i);
      });
      for (std::size_t i = 0; i < out.size(); ++i) bad += out[i] != static_cast<int>(i);
      std::fill(out.begin(), out.end(), -1);
    }
  });
  for (int round = 0; round < 40; ++round) {
    set_num_threads(round % 4 == 0 ? 1 : round % 4 == 1 ? 8 : round % 4 == 2 ? 0 : 3);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  stop = true;
  worker.join();
  set_num_threads(0);
  CHECK(bad == 0);
}

TEST_CASE("parallel: parallel_tasks runs every task once, in order on one thread", "[autodiff][parallel]") {
  {
    ThreadCount one(1);
    std::vector<int> order;
    parallel_tasks(5, [&](int i) { order.push_back(i); });
    CHECK(order == std::vector<int>{0, 1, 2, 3, 4});
  }
  ThreadCount four(4);
  std::vector<std::atomic<int>> runs(37);
  parallel_tasks(37, [&](int i) { ++runs[i]; });
  for (const auto& r : runs) CHECK(r == 1);
  parallel_tasks(0, [](int) { FAIL("no task to run"); });
}

TEST_CASE("parallel: tasks record and differentiate on their own tapes while their inner loops run in parallel",
          "[autodiff][parallel][tape]") {
  // Each task: loss_i = sum((x * (i + 1))^2) over a vector large enough that
  // the elementwise ops split; d loss_i / dx = 2 (i + 1)^2 x.
  const Tensor x0 = Tensor::full({300000}, 0.5);
  auto gradients = [&] {
    std::vector<double> g(6);
    parallel_tasks(6, [&](int i) {
      ScopedTape tape;
      Tensor x = x0.detach().set_requires_grad();
      backward(sum(pow(x * double(i + 1), 2.0)));
      g[i] = x.grad().to_vector()[12345];
    });
    return g;
  };
  std::vector<double> serial;
  {
    ThreadCount one(1);
    serial = gradients();
  }
  for (int i = 0; i < 6; ++i) CHECK(serial[i] == 2.0 * (i + 1) * (i + 1) * 0.5);
  for (int threads : {2, 3, 8}) {
    ThreadCount n(threads);
    CHECK(gradients() == serial);
  }
}

TEST_CASE("parallel: inside a SerialScope loops run inline on the calling thread", "[autodiff][parallel]") {
  ThreadCount four(4);
  std::set<std::thread::id> ids;
  std::mutex m;
  {
    SerialScope serial;
    parallel_for(0, 1 << 20, 1, [&](std::int64_t, std::int64_t) {
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    });
  }
  CHECK(ids == std::set<std::thread::id>{std::this_thread::get_id()});
  // And in parallel again after it. A worker may not get a CPU within one
  // 160 ms window on a loaded machine (a pip build beside the tests), so up to
  // five windows; a scope that left the loops serial fails all five.
  std::size_t seen = 1;
  for (int window = 0; window < 5 && seen <= 1; ++window) seen = distinct_threads(8, std::chrono::milliseconds(20));
  CHECK(seen > 1);
}
