// Data-parallel gradients whose bits do not depend on how the views are split
// over processes (issue 15, docs/scaling.md).
//
// A plain allreduce adds the processes' partial sums in an order that depends
// on their number, so P = 1, 2, 3 drift apart. Here every view's gradient is
// kept separately, all of them are gathered to every process, and each
// process adds them in view order 0, 1, ..., V-1 in float64: the same
// additions, in the same order, for any P (and for the single-process run,
// which goes through the same code with SingleProcess). The cost: each
// process holds and receives V gradient vectors instead of one (see
// docs/scaling.md for when that matters and what would replace it).
//
//   gr::ViewGradients grads({vertices, colours}, num_views, 1);  // 1 value per view: its loss
//   for (int v : my_views) {                       // views_of_rank(...)
//     gr::Tensor loss = render_loss(v) / double(num_views);
//     gr::backward(loss);
//     grads.take(v, {loss.item()});                // moves the params' grads aside
//   }
//   std::vector<double> totals = grads.reduce(comm); // every view, in view order
//   adam.step();                                    // the same step on every process
//   adam.zero_grad();
#pragma once

#include <exception>
#include <mutex>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/tensor.h"

namespace gr {

// What the reduction needs of a group of processes.
class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Every process passes its values (counts may differ); every process gets
  // all of them, concatenated in rank order, in `all` (its capacity is reused).
  virtual void all_gather(const std::vector<double>& mine, std::vector<double>& all) = 0;
};

// Thrown on every process of a group when one of them failed (see
// raise_if_any_failed): each can then end cleanly instead of waiting forever
// in a collective call the failed one never reaches.
struct ProcessFailed : Error {
  int failed_rank;
  ProcessFailed(int rank, const std::string& what) : Error(what), failed_rank(rank) {}
};

// Collective: every process of `comm` calls it with its own failure (null if
// none). If no process failed it returns. Otherwise every process throws
// ProcessFailed naming the lowest failed rank and its message; a group of one
// rethrows its own exception unchanged.
void raise_if_any_failed(Communicator& comm, const std::exception_ptr& failure);

// A group of one: rank 0 of 1.
class SingleProcess : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void all_gather(const std::vector<double>& mine, std::vector<double>& all) override { all = mine; }
};

// The views process `rank` of `size` renders: a contiguous block [begin, end),
// the first views % size processes taking one more.
struct ViewRange {
  int begin = 0, end = 0;
};
ViewRange views_of_rank(int views, int rank, int size);

class ViewGradients {
 public:
  // params: leaves requiring grad (float32 or float64); views: how many views
  // the loss sums over, on all processes together; values_per_view: how many
  // numbers each view reports besides its gradient (its loss, a metric).
  ViewGradients(std::vector<Tensor> params, int views, int values_per_view = 0);

  // Takes view `view`'s contribution: each param's current gradient (zeros if
  // it has none) is copied aside and the param's gradient is cleared, so the
  // next view's backward starts from nothing. `values` (values_per_view of
  // them) are summed over views the same way. Each view once per iteration;
  // throws ValueError otherwise.
  void take(int view, const std::vector<double>& values = {});

  // Views evaluated concurrently (each on its own thread and tape) cannot
  // share the params' gradients. Each view instead differentiates its own
  // leaves, from view_leaves(): the params' values (shared storage, not
  // copied) with a gradient of their own. take(view, leaves, values) then
  // takes that view's contribution from them (clearing their gradients); it
  // may be called from several threads at once, for different views.
  //   gr::parallel_tasks(views, [&](int v) {
  //     gr::ScopedTape tape;
  //     std::vector<gr::Tensor> mine = grads.view_leaves();
  //     gr::Tensor loss = render_loss(v, mine) / double(views);
  //     gr::backward(loss);
  //     grads.take(v, mine, {loss.item()});
  //   });
  std::vector<Tensor> view_leaves() const;
  void take(int view, const std::vector<Tensor>& leaves, const std::vector<double>& values);

  // Gathers every view's contribution (the views this process did not take
  // come from the others), sets each param's gradient to the sum over views in
  // view order (float64, rounded once to the param's dtype) and returns the
  // summed values. Throws ValueError if some view was taken by no process or by
  // two. Afterwards the object is ready for the next iteration; keep it across
  // iterations, so its buffers (views x parameters doubles) are reused rather
  // than allocated and paged in again. The calling thread's tape is left as it
  // was (a graph recorded before reduce() can still be backpropagated).
  std::vector<double> reduce(Communicator& comm);

 private:
  std::vector<Tensor> params_;
  int views_;
  std::size_t values_per_view_;
  std::size_t gradient_length_ = 0;  // sum of the params' element counts
  // records_[v]: view v's [view index, values..., gradients...], written by
  // take (each view's own buffer, reused across iterations); taken_ their
  // concatenation in take order, for the other processes.
  std::vector<std::vector<double>> records_;
  std::vector<double> taken_, gathered_, sum_;
  std::vector<int> taken_views_;
  std::mutex mutex_;  // guards taken_views_ (take from several threads)
};

}  // namespace gr
