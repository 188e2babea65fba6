// ViewGradients (autodiff/view_gradients.h): gradients summed over views give
// the same bits however the views are split over processes. Processes are
// simulated by threads (each records on its own tape) sharing a gather.
#include <catch2/catch.hpp>

#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "autodiff/view_gradients.h"
#include "ops/ops.h"

using namespace gr;

namespace {

// A group of `size` threads: all_gather waits until every member has given
// its values, then hands each the concatenation in rank order.
class ThreadGroup {
 public:
  explicit ThreadGroup(int size) : size_(size), parts_(static_cast<std::size_t>(size)) {}

  std::vector<double> all_gather(int rank, const std::vector<double>& mine) {
    std::unique_lock<std::mutex> lock(mutex_);
    const int round = round_;
    parts_[rank] = mine;
    if (++arrived_ == size_) {
      result_.clear();
      for (const auto& p : parts_) result_.insert(result_.end(), p.begin(), p.end());
      arrived_ = 0;
      ++round_;
      done_.notify_all();
    } else {
      done_.wait(lock, [&] { return round_ != round; });
    }
    return result_;
  }
  int size() const { return size_; }

 private:
  int size_, arrived_ = 0, round_ = 0;
  std::vector<std::vector<double>> parts_;
  std::vector<double> result_;
  std::mutex mutex_;
  std::condition_variable done_;
};

class ThreadMember : public Communicator {
 public:
  ThreadMember(ThreadGroup& group, int rank) : group_(group), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return group_.size(); }
  void all_gather(const std::vector<double>& mine, std::vector<double>& all) override {
    all = group_.all_gather(rank_, mine);
  }

 private:
  ThreadGroup& group_;
  int rank_;
};

constexpr int kViews = 7;

// One process's iteration: its views' losses sum(w * x_v)^2 / views (x_v
// differs per view, with magnitudes from 1e-8 to 1e8 so the summation order
// shows), reduced over the group. Returns [total loss, w's gradient...].
std::vector<double> run_member(Communicator& comm) {
  Tensor w = Tensor::from_values({0.3, -1.7, 2.5, 1e-3}, {4}, DType::Float32).set_requires_grad();
  Tensor b = Tensor::from_values({0.1}, {1}, DType::Float64).set_requires_grad();
  ViewGradients grads({w, b}, kViews, 1);
  const ViewRange mine = views_of_rank(kViews, comm.rank(), comm.size());
  for (int v = mine.begin; v < mine.end; ++v) {
    const double scale = std::pow(10.0, 2 * v - 6);
    Tensor x = Tensor::from_values({scale, 1.0 / 3, -scale, 7.0}, {4}, DType::Float32);
    Tensor loss = pow(sum(w * x), 2.0) / double(kViews) + sum(b * double(v + 1)) / double(kViews);
    backward(loss);
    grads.take(v, {loss.item()});
  }
  std::vector<double> out = grads.reduce(comm);
  for (double g : w.grad().to_vector()) out.push_back(g);
  for (double g : b.grad().to_vector()) out.push_back(g);
  return out;
}

std::vector<std::vector<double>> run_group(int size) {
  ThreadGroup group(size);
  std::vector<std::vector<double>> results(static_cast<std::size_t>(size));
  std::vector<std::thread> threads;
  for (int r = 0; r < size; ++r)
    threads.emplace_back([&, r] {
      ThreadMember member(group, r);
      results[r] = run_member(member);
    });
  for (auto& t : threads) t.join();
  return results;
}

}  // namespace

TEST_CASE("view gradients: views are split into contiguous blocks covering every view once", "[autodiff][distributed]") {
  for (int size = 1; size <= 9; ++size) {
    int next = 0;
    for (int rank = 0; rank < size; ++rank) {
      const ViewRange r = views_of_rank(kViews, rank, size);
      CHECK(r.begin == next);
      CHECK(r.end - r.begin >= kViews / size);
      next = r.end;
    }
    CHECK(next == kViews);
  }
  CHECK_THROWS_AS(views_of_rank(7, 3, 3), ValueError);
}

TEST_CASE("view gradients: the summed loss and gradients are the same bits for 1 to 4 processes",
          "[autodiff][distributed][determinism]") {
  SingleProcess alone;
  const std::vector<double> reference = run_member(alone);
  for (int size = 1; size <= 4; ++size) {
    const auto results = run_group(size);
    for (int r = 0; r < size; ++r) {
      INFO(size << " processes, rank " << r);
      CHECK(results[r] == reference);
    }
  }
  // Not vacuous: these views' gradients round differently when added in another
  // order (checked by reversing the order for 2 processes: this case fails).
}

TEST_CASE("view gradients: a failure on one process reaches every process with its rank and message",
          "[autodiff][distributed][errors]") {
  ThreadGroup group(3);
  std::vector<std::string> seen(3);
  std::vector<std::thread> threads;
  for (int r = 0; r < 3; ++r)
    threads.emplace_back([&, r] {
      ThreadMember member(group, r);
      std::exception_ptr failure;
      if (r == 1) failure = std::make_exception_ptr(ValueError("bad view 4"));
      try {
        raise_if_any_failed(member, failure);
      } catch (const ProcessFailed& e) {
        seen[r] = e.what();
      }
    });
  for (auto& t : threads) t.join();
  for (const std::string& s : seen) CHECK(s == "process 1 of 3 failed: bad view 4");
  // Alone, the original exception comes back unchanged.
  SingleProcess alone;
  CHECK_THROWS_AS(raise_if_any_failed(alone, std::make_exception_ptr(MemoryError("m"))), MemoryError);
  CHECK_NOTHROW(raise_if_any_failed(alone, nullptr));
}

TEST_CASE("view gradients: a view taken twice or by no process is refused", "[autodiff][distributed][errors]") {
  Tensor w = Tensor::from_values({1.0}, {1}, DType::Float64).set_requires_grad();
  ViewGradients grads({w}, 3);
  grads.take(0);
  CHECK_THROWS_WITH(grads.take(0), Catch::Contains("taken twice"));
  CHECK_THROWS_AS(grads.take(3), ValueError);
  SingleProcess alone;
  CHECK_THROWS_WITH(grads.reduce(alone), Catch::Contains("no process took view 1"));
  CHECK_THROWS_AS(ViewGradients({Tensor::zeros({2})}, 3), ValueError);  // not requiring grad
}

namespace {

// run_member's views on one process, evaluated concurrently by parallel_tasks:
// each view on its own tape, differentiating its own aliases of w and b.
std::vector<double> run_concurrent_views() {
  Tensor w = Tensor::from_values({0.3, -1.7, 2.5, 1e-3}, {4}, DType::Float32).set_requires_grad();
  Tensor b = Tensor::from_values({0.1}, {1}, DType::Float64).set_requires_grad();
  ViewGradients grads({w, b}, kViews, 1);
  parallel_tasks(kViews, [&](int v) {
    ScopedTape tape;
    const std::vector<Tensor> mine = grads.view_leaves();
    const double scale = std::pow(10.0, 2 * v - 6);
    Tensor x = Tensor::from_values({scale, 1.0 / 3, -scale, 7.0}, {4}, DType::Float32);
    Tensor loss = pow(sum(mine[0] * x), 2.0) / double(kViews) + sum(mine[1] * double(v + 1)) / double(kViews);
    backward(loss);
    grads.take(v, mine, {loss.item()});
  });
  SingleProcess one;
  std::vector<double> out = grads.reduce(one);
  for (double g : w.grad().to_vector()) out.push_back(g);
  for (double g : b.grad().to_vector()) out.push_back(g);
  return out;
}

}  // namespace

TEST_CASE("view gradients: views evaluated concurrently on their own leaves give the sequential bits for any thread count",
          "[autodiff][distributed][parallel]") {
  const std::vector<double> sequential = run_group(1)[0];
  for (int threads : {1, 2, 3, 8}) {
    set_num_threads(threads);
    INFO(threads << " threads");
    CHECK(run_concurrent_views() == sequential);
  }
  set_num_threads(0);
}

TEST_CASE("view gradients: a long gradient is summed in view order, the same bits for any thread count",
          "[autodiff][distributed][parallel]") {
  // Long enough that reduce splits its sum over threads; values of mixed
  // magnitudes, so that another order of additions would round differently.
  constexpr int kLongViews = 5;
  constexpr std::int64_t kLength = 50000;
  auto view_gradient = [](int v) {
    std::vector<double> g(static_cast<std::size_t>(kLength));
    for (std::int64_t i = 0; i < kLength; ++i)
      g[static_cast<std::size_t>(i)] = std::pow(10.0, double((i + v) % 9) - 4.0) * (((i * 7 + v) % 5) - 2.0) / 3.0;
    return g;
  };
  std::vector<std::vector<double>> view_gradients;
  for (int v = 0; v < kLongViews; ++v) view_gradients.push_back(view_gradient(v));
  std::vector<double> expected(static_cast<std::size_t>(kLength));
  for (std::size_t i = 0; i < expected.size(); ++i) {
    double sum = 0;
    for (const std::vector<double>& g : view_gradients) sum += double(float(g[i]));
    expected[i] = double(float(sum));
  }
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    INFO(threads << " threads");
    Tensor p = Tensor::zeros({kLength}, DType::Float32).set_requires_grad();
    ViewGradients grads({p}, kLongViews, 1);
    for (int v = 0; v < kLongViews; ++v) {
      ScopedTape tape;
      const std::vector<Tensor> mine = grads.view_leaves();
      backward(sum(mine[0] * Tensor::from_values(view_gradients[static_cast<std::size_t>(v)], {kLength}, DType::Float32)));
      grads.take(v, mine, {double(v)});
    }
    SingleProcess one;
    CHECK(grads.reduce(one) == std::vector<double>{0.0 + 1 + 2 + 3 + 4});
    CHECK(p.grad().to_vector() == expected);
  }
  set_num_threads(0);
}

TEST_CASE("view gradients: a view's leaves share the params' values but not their gradients", "[autodiff][distributed]") {
  Tensor w = Tensor::from_values({1, 2}, {2}).set_requires_grad();
  ViewGradients grads({w}, 2, 0);
  const std::vector<Tensor> mine = grads.view_leaves();
  REQUIRE(mine.size() == 1);
  CHECK(mine[0].is_leaf());
  CHECK(mine[0].requires_grad());
  CHECK(mine[0].to_vector() == w.to_vector());
  backward(sum(mine[0] * 3.0));
  CHECK_FALSE(w.has_grad());
  grads.take(0, mine, {});
  CHECK_FALSE(mine[0].has_grad());  // taken: the next view starts from nothing
}

TEST_CASE("view gradients: leaves of the wrong count or shape are refused, naming the view", "[autodiff][distributed][errors]") {
  Tensor w = Tensor::from_values({1, 2}, {2}).set_requires_grad();
  Tensor b = Tensor::from_values({1}, {1}).set_requires_grad();
  ViewGradients grads({w, b}, 2, 0);
  CHECK_THROWS_WITH(grads.take(1, {w}, {}), Catch::Contains("view 1 gives 1 leaves, expected one per param (2)"));
  CHECK_THROWS_AS(grads.take(1, {b, w}, {}), ShapeError);
  CHECK_THROWS_WITH(grads.take(1, {b, w}, {}), Catch::Contains("view 1's leaves[0]"));
}

TEST_CASE("view gradients: reduce leaves a graph recorded before it on the caller's tape", "[autodiff][distributed][tape]") {
  Tensor w = Tensor::from_values({1, 2}, {2}).set_requires_grad();
  Tensor u = Tensor::from_values({3, 4}, {2}).set_requires_grad();
  ViewGradients grads({w}, 1, 0);
  const Tensor recorded = sum(u * u);  // before reduce, on this thread's tape
  {
    ScopedTape view_tape;  // the view's own recording
    backward(sum(w * 2.0));
    grads.take(0, {});
  }
  SingleProcess one;
  grads.reduce(one);
  CHECK(w.grad().to_vector() == std::vector<double>{2, 2});
  backward(recorded);  // still differentiable
  CHECK(u.grad().to_vector() == std::vector<double>{6, 8});
}
