// The gradient tape: a Wengert list of recorded operations, one per thread.
//
// Every op in ops/ that has an input requiring a gradient appends one Node
// holding its inputs, the values its adjoint needs (captured by the closure)
// and the adjoint itself. backward() walks the list once in reverse: no
// recursion, no topological sort. Each node's closure and saved inputs are
// released as soon as the sweep has passed it.
//
// The rule: backward() ends a recording. When it returns, the tape is empty
// (keeping its capacity, so a loop that builds the same graph stops
// allocating), including the nodes recorded after the output (a psnr =
// -10 log(loss) logged before backward(loss)); such tensors keep their values,
// but using them in a new recorded op or in backward() throws TapeError. So a
// training loop's tape never grows from one iteration to the next. Compute what
// you only log under NoGradGuard, or after backward from detach()ed values.
//
// In-place writes: with every tensor it records (an op's inputs, outputs and
// the index tensors its adjoint reads, such as triangles), the tape saves its
// storage's version (autodiff/base/storage.h), which every call of the non-const
// Tensor::data<T>() bumps, through any handle sharing the storage (detach()).
// Before a node's adjoint runs, backward() checks that none of them was
// written since, and otherwise throws TapeError naming the op and the input or
// output: the adjoint would compute the gradient from the new values (y = x *
// w; writing w before backward() changes dL/dx). So between the forward
// computation and backward(), write into a copy() of a recorded tensor, read
// it through the const data<T>() (taking the non-const one only to read counts
// as a write too), and write parameters (an optimizer step) after backward().
// Every input counts, also one whose values the adjoint does not use (sum's):
// one rule, no list of exceptions. Only nodes the sweep runs are checked, and
// only tensors still alive (a freed one cannot have been written). Gradients
// added by the nodes swept before the throw stay: zero_grad() before retrying.
//
// Threads: each thread records on its own tape, each tape has a process-unique
// id, and every recorded tensor remembers it. A graph is recorded and
// backpropagated on one thread: a recorded tensor given to another thread's
// recorded op or backward() throws TapeError naming both tapes (detach() it to
// pass its values as a constant). Leaves may be shared: two threads may
// backpropagate into the same parameter at once; its gradient then receives
// both contributions (accumulate_leaf_grad locks the leaf), in an order, and so
// with a float rounding, that depends on the threads' timing.
//
// Writing an op:
//   Tensor out = ...forward kernel...;
//   if (should_record({a, b}))
//     record("mul", {a, b}, {out}, [a, b](AdjointContext& ctx) {
//       const Tensor& g = ctx.grad_output(0);
//       if (ctx.needs_grad(0)) ctx.accumulate(0, g * b);   // dL/da = g b
//       if (ctx.needs_grad(1)) ctx.accumulate(1, g * a);   // dL/db = g a
//     });
// Tensors the adjoint reads that take no gradient (triangles, a G-buffer's
// tri_id, gather's index, where's mask) go after the differentiable inputs,
// detach()ed if they might require grad: needs_grad() is false for them, and
// backward() checks them for in-place writes like the rest. An op reads its
// inputs through the const data<T>() (std::as_const), also after recording
// them: the non-const one counts as a write.
// Adjoints run with recording switched off.
#pragma once

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

class AdjointContext;
using Adjoint = std::function<void(AdjointContext&)>;

class Tape {
 public:
  Tape();
  Tape(const Tape&) = delete;
  Tape& operator=(const Tape&) = delete;

  // The calling thread's tape.
  static Tape& current();

  // Number of nodes recorded and not yet cleared.
  std::size_t size() const { return nodes_.size(); }
  // Drops every node and its saved values. Tensors recorded before can no
  // longer be differentiated (backward on them, or using them as inputs of a
  // new recorded op, throws TapeError).
  void clear();
  std::uint64_t generation() const { return generation_; }
  // Process-unique: no two tapes (threads) share one.
  std::uint64_t id() const { return id_; }

  // Internal: used by record() and backward().
  void append(const char* name, std::vector<Tensor> inputs, const std::vector<Tensor*>& outputs, Adjoint adjoint);
  void run_backward(const Tensor& output, const Tensor& upstream);

 private:
  // A recorded tensor's storage and its version at record time. Weak: the
  // check keeps no tensor alive, and a storage freed (its buffer maybe recycled
  // into another tensor) is simply not checked.
  struct SavedVersion {
    std::weak_ptr<Storage> storage;
    std::uint64_t version = 0;
    static SavedVersion of(const TensorImpl& t);
    // True if the storage is still alive and was written since.
    bool written() const;
  };
  // What the sweep needs of an input: where its gradient goes, what shape it
  // must have and its saved version. Not the tensor itself, so an input's
  // values stay alive only if the op's adjoint captured them (a sum needs only
  // its input's shape).
  struct InputRef {
    SavedVersion saved;
    bool defined = false;
    bool requires_grad = false;
    Shape shape;
    DType dtype = DType::Float32;
    std::int64_t slot = -1;              // recorded input: its gradient slot
    std::shared_ptr<TensorImpl> leaf;    // leaf requiring grad: where .grad accumulates
  };
  struct Node {
    const char* name = "";
    std::vector<InputRef> inputs;
    std::vector<std::int64_t> output_slots;
    Adjoint adjoint;  // empty once swept
  };
  void give_zero_grads(Node& node);
  // Throws TapeError if an input or output of `node` was written in place since it was recorded.
  void check_not_written(const Node& node) const;
  friend class AdjointContext;
  // Throws TapeError (naming `what`) unless recorded tensor `t` belongs to this
  // tape's current recording.
  void check_recorded_here(const TensorImpl& t, const std::string& what) const;
  const std::uint64_t id_;
  std::vector<Node> nodes_;
  std::vector<std::int64_t> node_of_slot_;
  std::vector<SavedVersion> output_versions_;  // by gradient slot
  std::vector<Tensor> slot_grads_;
  std::uint64_t generation_ = 1;
};

// Passed to an adjoint: gradients of the node's outputs, and where to put the
// gradients of its inputs.
class AdjointContext {
 public:
  // dL/d(output i); undefined if no gradient reached that output.
  const Tensor& grad_output(std::size_t i = 0) const;
  // True if input i requires a gradient (skip computing the others).
  bool needs_grad(std::size_t input) const;
  // Adds `grad` (same shape and dtype as input i) into dL/d(input i).
  void accumulate(std::size_t input, const Tensor& grad);
  // For kernels that add into a buffer (+=): a buffer whose contents the
  // adjoint adds its part of dL/d(input i) to, instead of calling accumulate.
  // For a recorded input it is the gradient summed so far when nothing else
  // holds it (no zero fill, no addition pass), else a copy of that sum, or
  // zeros if there is none yet. For a leaf it is zeros, added to the leaf's
  // gradient when the adjoint returns. Undefined if input i needs no gradient.
  Tensor accumulation_buffer(std::size_t input);
  // Shape and dtype of input i (adjoints that reduce a broadcast gradient need them).
  const Shape& input_shape(std::size_t i) const { return node_.inputs.at(i).shape; }
  DType input_dtype(std::size_t i) const { return node_.inputs.at(i).dtype; }

 private:
  friend class Tape;
  AdjointContext(Tape& tape, Tape::Node& node) : tape_(tape), node_(node) {}
  // Adds the leaves' accumulation buffers to their gradients (after the adjoint).
  void add_leaf_buffers();
  Tape& tape_;
  Tape::Node& node_;
  std::vector<std::pair<std::size_t, Tensor>> leaf_buffers_;
};

// True if gradient mode is on and any defined tensor in `inputs` requires grad.
bool should_record(std::initializer_list<Tensor> inputs);
bool should_record(const std::vector<Tensor>& inputs);
// Records an op on the current tape; marks `outputs` as requiring grad.
void record(const char* name, std::vector<Tensor> inputs, std::initializer_list<Tensor*> outputs, Adjoint adjoint);
void record(const char* name, std::vector<Tensor> inputs, const std::vector<Tensor*>& outputs, Adjoint adjoint);

// Reverse sweep from a scalar (one-element) loss, seeding dL/dL = 1.
void backward(const Tensor& loss);
// Reverse sweep from any output with an explicit upstream gradient of its shape.
void backward(const Tensor& output, const Tensor& upstream_grad);

// Turns recording off for its lifetime (nested scopes are fine).
class NoGradGuard {
 public:
  NoGradGuard();
  ~NoGradGuard();
  NoGradGuard(const NoGradGuard&) = delete;
  NoGradGuard& operator=(const NoGradGuard&) = delete;

 private:
  bool previous_;
};

bool grad_mode_enabled();

// Records on a fresh tape of its own, with gradient mode on, for its lifetime:
// a graph built and backpropagated inside it never touches the thread's tape,
// so it may run inside an adjoint (map_rows recomputes a block's graph this
// way) or inside a parallel_for body. Scopes nest like a stack, on one thread.
class ScopedTape {
 public:
  ScopedTape();
  ~ScopedTape();
  ScopedTape(const ScopedTape&) = delete;
  ScopedTape& operator=(const ScopedTape&) = delete;

 private:
  Tape tape_;
  Tape* previous_tape_;
  bool previous_grad_mode_;
};

}  // namespace gr
