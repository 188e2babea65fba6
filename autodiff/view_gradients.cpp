#include "autodiff/view_gradients.h"

#include <algorithm>

#include "autodiff/base/dtype.h"
#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"

namespace gr {

void raise_if_any_failed(Communicator& comm, const std::exception_ptr& failure) {
  if (comm.size() == 1) {
    if (failure) std::rethrow_exception(failure);
    return;
  }
  // Each process sends [failed, message length, message bytes...] as doubles.
  std::string message;
  if (failure) {
    try {
      std::rethrow_exception(failure);
    } catch (const std::exception& e) {
      message = e.what();
    } catch (...) {
      message = "an unknown exception";
    }
  }
  std::vector<double> mine{failure ? 1.0 : 0.0, double(message.size())};
  for (unsigned char c : message) mine.push_back(double(c));
  std::vector<double> all;
  comm.all_gather(mine, all);
  std::size_t at = 0;
  for (int rank = 0; rank < comm.size() && at + 1 < all.size(); ++rank) {
    const std::size_t length = static_cast<std::size_t>(all[at + 1]);
    if (all[at] != 0) {
      std::string text;
      for (std::size_t i = 0; i < length; ++i) text.push_back(static_cast<char>(all[at + 2 + i]));
      throw ProcessFailed(rank, "process " + std::to_string(rank) + " of " + std::to_string(comm.size()) +
                                    " failed: " + text);
    }
    at += 2 + length;
  }
}

ViewRange views_of_rank(int views, int rank, int size) {
  if (size < 1 || rank < 0 || rank >= size || views < 0)
    throw ValueError("views_of_rank: need 0 <= rank < size and views >= 0, got rank " + std::to_string(rank) +
                     ", size " + std::to_string(size) + ", views " + std::to_string(views));
  const int base = views / size, extra = views % size;
  ViewRange r;
  r.begin = rank * base + std::min(rank, extra);
  r.end = r.begin + base + (rank < extra ? 1 : 0);
  return r;
}

ViewGradients::ViewGradients(std::vector<Tensor> params, int views, int values_per_view)
    : params_(std::move(params)), views_(views), values_per_view_(static_cast<std::size_t>(std::max(values_per_view, 0))) {
  if (views < 1) throw ValueError("ViewGradients: views must be at least 1, got " + std::to_string(views));
  if (values_per_view < 0)
    throw ValueError("ViewGradients: values_per_view must be >= 0, got " + std::to_string(values_per_view));
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Tensor& p = params_[i];
    const std::string name = "ViewGradients: params[" + std::to_string(i) + "]";
    if (!p.defined()) throw ValueError(name + " is undefined");
    if (!is_floating(p.dtype())) throw DTypeError(name + " must be float32 or float64, got " + p.describe());
    if (!p.requires_grad() || !p.is_leaf()) throw ValueError(name + " must be a leaf that requires grad");
    gradient_length_ += static_cast<std::size_t>(p.numel());
  }
  records_.resize(static_cast<std::size_t>(views));
}

void ViewGradients::take(int view, const std::vector<double>& values) { take(view, params_, values); }

std::vector<Tensor> ViewGradients::view_leaves() const {
  std::vector<Tensor> leaves;
  for (const Tensor& p : params_) leaves.push_back(p.detach().set_requires_grad());
  return leaves;
}

void ViewGradients::take(int view, const std::vector<Tensor>& leaves, const std::vector<double>& values) {
  if (view < 0 || view >= views_)
    throw ValueError("ViewGradients::take: view " + std::to_string(view) + " is outside [0, " +
                     std::to_string(views_) + ")");
  if (values.size() != values_per_view_)
    throw ValueError("ViewGradients::take: view " + std::to_string(view) + " gives " +
                     std::to_string(values.size()) + " values, expected " + std::to_string(values_per_view_));
  if (leaves.size() != params_.size())
    throw ValueError("ViewGradients::take: view " + std::to_string(view) + " gives " + std::to_string(leaves.size()) +
                     " leaves, expected one per param (" + std::to_string(params_.size()) + ")");
  for (std::size_t i = 0; i < leaves.size(); ++i)
    if (!leaves[i].defined() || leaves[i].shape() != params_[i].shape() || leaves[i].dtype() != params_[i].dtype())
      throw ShapeError("ViewGradients::take: view " + std::to_string(view) + "'s leaves[" + std::to_string(i) +
                       "] is " + leaves[i].describe() + ", expected the shape and dtype of " + params_[i].describe());

  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::find(taken_views_.begin(), taken_views_.end(), view) != taken_views_.end())
      throw ValueError("ViewGradients::take: view " + std::to_string(view) + " was taken twice");
    taken_views_.push_back(view);
  }
  // [view index, values..., gradients...] into the view's own buffer, outside
  // the lock (no other take writes it), copied once.
  std::vector<double>& record = records_[static_cast<std::size_t>(view)];
  record.assign(1, double(view));
  record.reserve(1 + values.size() + gradient_length_);
  record.insert(record.end(), values.begin(), values.end());
  for (const Tensor& leaf : leaves) {
    const std::size_t at = record.size(), n = static_cast<std::size_t>(leaf.numel());
    if (!leaf.has_grad()) {
      record.resize(at + n, 0.0);
      continue;
    }
    const Tensor g = leaf.grad();
    dispatch_float(g.dtype(), "ViewGradients::take", [&](auto tag) {
      using T = decltype(tag);
      const T* src = g.data<T>();
      record.insert(record.end(), src, src + n);  // exact: float32 -> float64
    });
    Tensor(leaf).zero_grad();
  }
}

std::vector<double> ViewGradients::reduce(Communicator& comm) {
  // One process: its records are all of them, read in place (copying them
  // was a fixed cost of every iteration, issue 31); else they are gathered.
  const bool alone = comm.size() == 1;
  if (!alone) {
    taken_.clear();
    for (const int v : taken_views_) taken_.insert(taken_.end(), records_[v].begin(), records_[v].end());
    comm.all_gather(taken_, gathered_);
  }
  const std::size_t values = values_per_view_, record = 1 + values + gradient_length_;
  // Where each view's record is.
  std::vector<const double*> record_of(static_cast<std::size_t>(views_), nullptr);
  if (alone) {
    for (const int v : taken_views_) record_of[v] = records_[v].data();
  } else {
    const std::vector<double>& all = gathered_;
    if (all.size() % record != 0)
      throw ValueError(
          "ViewGradients::reduce: the processes' records do not match (different params or values per view)");
    for (std::size_t at = 0; at < all.size(); at += record) {
      const double v = all[at];
      if (!(v >= 0 && v < views_) || record_of[static_cast<std::size_t>(v)])
        throw ValueError("ViewGradients::reduce: view " + std::to_string(v) +
                         " was taken by two processes or is invalid");
      record_of[static_cast<std::size_t>(v)] = all.data() + at;
    }
  }
  for (int v = 0; v < views_; ++v)
    if (!record_of[v]) throw ValueError("ViewGradients::reduce: no process took view " + std::to_string(v));

  // Sums in view order, float64, each element by one thread (so the same
  // additions for any thread count).
  // Blocks of kBlock elements keep their sums in registers across the views
  // (one store per element, not one per view: issue 31).
  std::vector<double>& sum = sum_;
  sum.resize(values + gradient_length_);
  for (int v = 0; v < views_; ++v) record_of[v] += 1;  // past the view's index
  parallel_for(0, static_cast<std::int64_t>(sum.size()), kElementwiseGrain / 4,
               [&](std::int64_t lo, std::int64_t hi) {
                 constexpr std::int64_t kBlock = 16;
                 const double* const* rec = record_of.data();
                 double* const out = sum.data();
                 const int views = views_;
                 std::int64_t i = lo;
                 for (; i + kBlock <= hi; i += kBlock) {
                   double acc[kBlock] = {};
                   for (int v = 0; v < views; ++v)
                     for (std::int64_t k = 0; k < kBlock; ++k) acc[k] += rec[v][i + k];
                   for (std::int64_t k = 0; k < kBlock; ++k) out[i + k] = acc[k];
                 }
                 for (; i < hi; ++i) {
                   double acc = 0;
                   for (int v = 0; v < views; ++v) acc += rec[v][i];
                   out[i] = acc;
                 }
               });
  std::size_t at = values;
  ScopedTape own_tape;  // setting the params' gradients leaves the caller's recording alone
  for (Tensor& p : params_) {
    const std::int64_t n = p.numel();
    Tensor g = Tensor::empty(p.shape(), p.dtype());
    dispatch_float(p.dtype(), "ViewGradients::reduce", [&](auto tag) {
      using T = decltype(tag);
      T* out = g.data<T>();
      for (std::int64_t i = 0; i < n; ++i) out[i] = T(sum[at + static_cast<std::size_t>(i)]);
    });
    p.zero_grad();
    backward(p, g);  // p is a leaf: its gradient becomes g
    at += static_cast<std::size_t>(n);
  }
  taken_.clear();
  taken_views_.clear();
  return std::vector<double>(sum.begin(), sum.begin() + static_cast<std::ptrdiff_t>(values));
}

}  // namespace gr
