// FusedRows::compile (ops/tensor/fused_rows.h): a trace of f on one block to the
// program the interpreter replays, or nullptr when it cannot replay it.
// Validate (the inputs have lanes enough to tell constants from rows),
// prepare (the inputs as values), record (each traced step as an instruction
// on values), plan the backward (liveness, which values receive a gradient,
// their arrays), and check that the lane arrays fit a thread's arena.
#include <unordered_map>
#include <unordered_set>

#include "ops/tensor/elementwise_table.h"
#include "ops/tensor/fused_rows_program.h"

namespace gr::detail {

namespace {

// The lanes: every axis of a row input but its last ([P] for [P, C], [P, W]
// for an image's [P, W, C]); values with a last axis share them.
std::vector<std::int64_t> lane_dims_of(const std::vector<Tensor>& rows, std::int64_t P) {
  std::vector<std::int64_t> lane_dims{P};
  for (const Tensor& t : rows)
    if (t.defined() && t.rank() >= 2) {
      const std::vector<std::int64_t> d = t.shape().dims();
      lane_dims.assign(d.begin(), d.end() - 1);
      break;
    }
  return lane_dims;
}

int width_of(const Tensor& t) { return t.rank() == 1 ? 1 : int(t.size(-1)); }
int rank_of(const Tensor& t) { return t.rank() == 1 ? 1 : 2; }

}  // namespace

// compile's working state: the program being built, the lanes' shape, and the
// traced tensors seen so far, as values (ids) or as not replayable (opaque:
// using one fails the step).
struct FusedRows::Compiler {
  FusedRows& p;
  std::int64_t P;
  std::vector<std::int64_t> lane_dims;
  std::unordered_map<const TensorImpl*, int> ids;
  std::unordered_set<const TensorImpl*> opaque;

  int add_varying(int rank, int width) {
    Value v;
    v.varying = true, v.rank = rank, v.width = width, v.array = p.arena_arrays_;
    p.arena_arrays_ += width;
    p.values_.push_back(v);
    return int(p.values_.size()) - 1;
  }

  int add_uniform(const Tensor& t) {
    Value v;
    v.width = int(t.numel()), v.array = std::int64_t(p.uniforms_.size());
    dispatch_float(t.dtype(), "map_rows", [&](auto tag) {
      const auto* d = t.data<decltype(tag)>();
      for (std::int64_t e = 0; e < t.numel(); ++e) p.uniforms_.push_back(double(d[e]));
    });
    p.values_.push_back(v);
    return int(p.values_.size()) - 1;
  }

  // [P] (one lane per row only) or the lanes' shape and a last axis.
  bool row_shaped(const Tensor& t) const {
    if (t.dtype() != p.dtype_ || t.rank() < 1 || t.size(0) != P) return false;
    if (t.rank() == 1) return p.lanes_per_row_ == 1;
    const std::vector<std::int64_t> d = t.shape().dims();
    return std::vector<std::int64_t>(d.begin(), d.end() - 1) == lane_dims && d.back() >= 1 &&
           d.back() <= kMaxArenaBytes;
  }

  // Prepare: the program's dtype and lanes per row, and its inputs as values.
  void prepare(DType dtype, std::int64_t lanes_per_row, const std::vector<Tensor>& rows,
               const std::vector<Tensor>& shared, const std::vector<bool>& rows_grad,
               const std::vector<bool>& shared_grad) {
    p.dtype_ = dtype;
    p.lanes_per_row_ = lanes_per_row;
    add_inputs(rows, shared, rows_grad, shared_grad);
  }

  // Record: each traced step as an instruction (or its result opaque); false
  // unless `result` is the value of an instruction.
  bool record(const FusionTrace& trace, const Tensor& result) {
    for (const TracedStep& s : trace.steps) add_step(s);
    const auto it = ids.find(result.impl());
    if (it == ids.end() || !p.values_[it->second].produced) return false;
    p.result_ = it->second;
    return true;
  }

  // The inputs' values: rows of the lanes' shape vary per lane, small shared
  // tensors are uniform; any other input is opaque.
  void add_inputs(const std::vector<Tensor>& rows, const std::vector<Tensor>& shared,
                  const std::vector<bool>& rows_grad, const std::vector<bool>& shared_grad) {
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Tensor& t = rows[i];
      int id = -1;
      if (row_shaped(t)) {
        id = add_varying(rank_of(t), width_of(t));
        p.values_[id].needs_grad = rows_grad[i];
        ids[t.impl()] = id;
      } else {
        opaque.insert(t.impl());
      }
      p.row_values_.push_back(id);
    }
    for (std::size_t j = 0; j < shared.size(); ++j) {
      const Tensor& t = shared[j];
      p.shared_shapes_.push_back(t.defined() ? t.shape() : Shape());
      int id = -1;
      if (t.defined() && t.dtype() == p.dtype_ && t.rank() <= 1 && t.numel() >= 1) {
        id = add_uniform(t);
        p.values_[id].needs_grad = shared_grad[j];
        ids[t.impl()] = id;
      } else if (t.defined()) {
        opaque.insert(t.impl());
      }
      p.shared_values_.push_back(id);
    }
  }

  // The value an operand refers to: known, or a small constant f captured; -1 if neither.
  int lookup(const Tensor& t) {
    if (!t.defined()) return -1;
    const auto it = ids.find(t.impl());
    if (it != ids.end()) return it->second;
    if (opaque.count(t.impl()) || t.requires_grad() || t.dtype() != p.dtype_ || t.rank() > 1 || t.numel() < 1 ||
        t.numel() > kMaxConstant)
      return -1;
    return ids[t.impl()] = add_uniform(t);
  }

  // How an operand is read at `components` components of a result of rank
  // out_rank: whole, spread (a column or a scalar) or not at all (-1).
  Operand operand(int id, int out_rank, int components) const {
    if (id < 0) return {};
    const Value& v = p.values_[id];
    if (v.varying) {
      if (v.rank == out_rank && v.width == components) return {id, false};
      if (out_rank == 2 && v.rank == 2 && v.width == 1) return {id, true};
      return {};
    }
    if (v.width == 1) return {id, true};
    if (out_rank == 2 && v.width == components) return {id, false};
    return {};
  }

  // Step s's op and operands into `in`; false if the interpreter cannot replay it.
  bool instruction(const TracedStep& s, Instr& in) {
    const bool unary = is_unary(s.op);
    in.op = s.op;
    in.param = s.param;
    in.param2 = s.param2;
    in.negate_b = negates_b(s.op);
    const int ida = lookup(s.a), idb = unary ? -1 : lookup(s.b);
    const bool shaped = row_shaped(s.out);
    bool ok = shaped && ida >= 0 && (unary || idb >= 0);
    const int out_rank = shaped ? rank_of(s.out) : 0, out_width = shaped ? width_of(s.out) : 0;
    if (ok) {
      if (s.op.kind == OpKind::Dot) {
        in.components = int(s.a.size(-1));
        ok = out_rank == 2 && out_width == 1 && s.b.size(-1) == in.components;
        if (ok) in.a = operand(ida, 2, in.components), in.b = operand(idb, 2, in.components);
        ok = ok && in.a.value >= 0 && in.b.value >= 0 && !in.a.spread && !in.b.spread;
      } else {
        in.components = out_width;
        in.a = operand(ida, out_rank, out_width);
        if (!unary) in.b = operand(idb, out_rank, out_width);
        ok = in.a.value >= 0 && (unary || in.b.value >= 0);
        if (ok && unary) ok = p.values_[ida].varying && !in.a.spread;                 // same shape as out
        if (ok && s.op.kind == OpKind::Normalize) ok = out_rank == 2;                      // rows of vectors
      }
      // At least one operand has rows (ops on shared values alone are not replayed).
      ok = ok && (p.values_[in.a.value].varying || (!unary && p.values_[in.b.value].varying));
    }
    return ok;
  }

  // Step s as an instruction writing a new value, or its result opaque.
  void add_step(const TracedStep& s) {
    Instr in;
    if (!instruction(s, in)) {
      opaque.insert(s.out.impl());
      return;
    }
    const bool unary = is_unary(s.op);
    in.out = add_varying(rank_of(s.out), width_of(s.out));
    Value& o = p.values_[in.out];
    o.produced = true;
    o.needs_grad = p.values_[in.a.value].needs_grad || (!unary && p.values_[in.b.value].needs_grad);
    if (s.op.kind == OpKind::Normalize) o.aux = p.arena_arrays_++;
    ids[s.out.impl()] = in.out;
    p.instrs_.push_back(in);
  }

  // Liveness (what the result depends on) and, in reverse order, which values
  // receive a gradient (returned) and which contribution to each comes first.
  std::vector<bool> mark_backward() {
    p.values_[p.result_].live = true;
    for (auto i = p.instrs_.rbegin(); i != p.instrs_.rend(); ++i)
      if (p.values_[i->out].live) {
        p.values_[i->a.value].live = true;
        if (i->b.value >= 0) p.values_[i->b.value].live = true;
      }
    std::vector<bool> has_grad(p.values_.size(), false);
    has_grad[p.result_] = p.values_[p.result_].needs_grad;
    for (auto i = p.instrs_.rbegin(); i != p.instrs_.rend(); ++i) {
      i->backward = has_grad[i->out] && p.values_[i->out].live;
      if (!i->backward) continue;
      auto take = [&](const Operand& o, bool& first) {
        if (o.value < 0 || !p.values_[o.value].needs_grad) return;
        first = !has_grad[o.value];
        has_grad[o.value] = true;
      };
      take(i->a, i->a_first);
      take(i->b, i->b_first);
    }
    return has_grad;
  }

  // Plan the backward: what the result depends on, which values receive a
  // gradient, and their arrays.
  void plan_backward() { place_gradients(mark_backward()); }

  // Each thread keeps its lane arrays between calls: rows too wide for that run per block.
  bool fits_arena() const { return p.arena_arrays_ * kLanes * std::int64_t(dtype_size(p.dtype_)) <= kMaxArenaBytes; }

  // Gradient arrays for the values that receive one: lane arrays for varying
  // values, double partial-sum arrays for shared ones.
  void place_gradients(const std::vector<bool>& has_grad) {
    for (std::size_t v = 0; v < p.values_.size(); ++v) {
      if (!has_grad[v]) continue;
      Value& val = p.values_[v];
      if (val.varying) {
        val.grad = p.arena_arrays_;
        p.arena_arrays_ += val.width;
      } else {
        val.grad = p.partial_arrays_;
        p.partial_arrays_ += val.width;
      }
    }
  }
};

namespace {

// Validate: the lanes' shape (lane_dims_of) and count, or false when f's call
// cannot be compiled: no rows, a result that is not float, or no more lanes
// than a constant may have elements (then a tensor derived from the rows by an
// op the trace does not know could pass for a constant).
bool compilable(const std::vector<Tensor>& rows, const Tensor& result, std::vector<std::int64_t>& lane_dims,
                std::int64_t& lanes) {
  if (rows.empty() || !result.defined() || !is_floating(result.dtype())) return false;
  const std::int64_t P = rows[0].size(0);
  lane_dims = lane_dims_of(rows, P);
  lanes = 1;
  for (std::int64_t d : lane_dims) lanes *= d;
  return P >= 1 && lanes > kMaxConstant;
}

}  // namespace

std::shared_ptr<const FusedRows> FusedRows::compile(const FusionTrace& trace, const std::vector<Tensor>& rows,
                                                    const std::vector<Tensor>& shared, const Tensor& result,
                                                    const std::vector<bool>& rows_grad, const std::vector<bool>& shared_grad) {
  std::vector<std::int64_t> lane_dims;
  std::int64_t lanes = 0;
  if (!compilable(rows, result, lane_dims, lanes)) return nullptr;
  auto prog = std::make_shared<FusedRows>();
  const std::int64_t P = rows[0].size(0);
  Compiler c{*prog, P, std::move(lane_dims), {}, {}};
  c.prepare(result.dtype(), lanes / P, rows, shared, rows_grad, shared_grad);
  if (!c.record(trace, result)) return nullptr;
  c.plan_backward();
  if (!c.fits_arena()) return nullptr;
  return prog;
}

}  // namespace gr::detail
