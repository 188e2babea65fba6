#include "autodiff/tape.h"

#include <atomic>
#include <cstring>

#include "autodiff/accumulate.h"

namespace gr {
namespace {
thread_local bool g_grad_mode = true;
thread_local Tape* g_scoped_tape = nullptr;  // innermost ScopedTape, if any
std::atomic<std::uint64_t> g_next_tape_id{1};

TapeError written_in_place(const char* op, const std::string& which) {
  return TapeError(std::string("backward: ") + which + " of '" + op +
                   "' was written in place (a non-const Tensor::data<T>(), through it or a handle sharing its "
                   "storage) after '" + op + "' was recorded, so its adjoint would compute the gradient from the new "
                   "values. Write into a copy() of the tensor, or write after backward(); to only read it between "
                   "the forward computation and backward(), use the const data<T>() (std::as_const(t).data<T>())");
}
}  // namespace

Tape::SavedVersion Tape::SavedVersion::of(const TensorImpl& t) { return {t.storage, t.storage->version()}; }

bool Tape::SavedVersion::written() const {
  const std::shared_ptr<Storage> s = storage.lock();
  return s && s->version() != version;
}

Tape::Tape() : id_(g_next_tape_id.fetch_add(1, std::memory_order_relaxed)) {}

NoGradGuard::NoGradGuard() : previous_(g_grad_mode) { g_grad_mode = false; }
NoGradGuard::~NoGradGuard() { g_grad_mode = previous_; }
bool grad_mode_enabled() { return g_grad_mode; }

Tape& Tape::current() {
  thread_local Tape tape;
  return g_scoped_tape ? *g_scoped_tape : tape;
}

ScopedTape::ScopedTape() : previous_tape_(g_scoped_tape), previous_grad_mode_(g_grad_mode) {
  g_scoped_tape = &tape_;
  g_grad_mode = true;
}

ScopedTape::~ScopedTape() {
  g_scoped_tape = previous_tape_;
  g_grad_mode = previous_grad_mode_;
}

void Tape::clear() {
  nodes_.clear();
  node_of_slot_.clear();
  output_versions_.clear();
  slot_grads_.clear();
  ++generation_;
}

bool should_record(const std::vector<Tensor>& inputs) {
  if (!g_grad_mode) return false;
  for (const Tensor& t : inputs)
    if (t.defined() && t.requires_grad()) return true;
  return false;
}

bool should_record(std::initializer_list<Tensor> inputs) {
  if (!g_grad_mode) return false;
  for (const Tensor& t : inputs)
    if (t.defined() && t.requires_grad()) return true;
  return false;
}

void Tape::check_recorded_here(const TensorImpl& t, const std::string& what) const {
  if (t.tape_id != id_)
    throw TapeError(what + " was recorded on tape " + std::to_string(t.tape_id) +
                    " (another thread's), but this thread's tape is " + std::to_string(id_) +
                    ": record and backpropagate a graph on one thread, or detach() the tensor to use its values "
                    "here as a constant");
  if (t.tape_generation != generation_)
    throw TapeError(what + " was recorded on a tape that has since been freed by backward() or Tape::clear() "
                    "(backward frees every node, also those recorded after its output); recompute it, or detach() "
                    "it to use it as a constant");
}

void Tape::append(const char* name, std::vector<Tensor> inputs, const std::vector<Tensor*>& outputs, Adjoint adjoint) {
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const TensorImpl* in = inputs[i].impl();
    if (in && in->recorded && in->requires_grad) check_recorded_here(*in, std::string(name) + ": input " + std::to_string(i));
  }
  Node node;
  node.name = name;
  node.inputs.reserve(inputs.size());
  for (const Tensor& t : inputs) {
    InputRef ref;
    if (t.defined()) {
      TensorImpl* impl = t.impl();
      ref.defined = true;
      ref.requires_grad = impl->requires_grad;
      ref.shape = impl->shape;
      ref.dtype = impl->dtype;
      ref.saved = SavedVersion::of(*impl);
      if (impl->recorded)
        ref.slot = impl->grad_slot;
      else if (impl->requires_grad)
        ref.leaf = t.impl_ptr();
    }
    node.inputs.push_back(std::move(ref));
  }
  node.adjoint = std::move(adjoint);
  for (Tensor* out : outputs) {
    TensorImpl* o = out->impl();
    o->requires_grad = true;
    o->recorded = true;
    o->tape_id = id_;
    o->tape_generation = generation_;
    o->grad_slot = static_cast<std::int64_t>(node_of_slot_.size());
    node_of_slot_.push_back(static_cast<std::int64_t>(nodes_.size()));
    output_versions_.push_back(SavedVersion::of(*o));
    node.output_slots.push_back(o->grad_slot);
  }
  nodes_.push_back(std::move(node));
}

void record(const char* name, std::vector<Tensor> inputs, const std::vector<Tensor*>& outputs, Adjoint adjoint) {
  Tape::current().append(name, std::move(inputs), outputs, std::move(adjoint));
}

void record(const char* name, std::vector<Tensor> inputs, std::initializer_list<Tensor*> outputs, Adjoint adjoint) {
  record(name, std::move(inputs), std::vector<Tensor*>(outputs), std::move(adjoint));
}

const Tensor& AdjointContext::grad_output(std::size_t i) const {
  return tape_.slot_grads_[static_cast<std::size_t>(node_.output_slots.at(i))];
}

bool AdjointContext::needs_grad(std::size_t input) const {
  const Tape::InputRef& in = node_.inputs.at(input);
  return in.defined && in.requires_grad;
}

void AdjointContext::accumulate(std::size_t input, const Tensor& grad) {
  const Tape::InputRef& in = node_.inputs.at(input);
  if (!in.defined || !in.requires_grad) return;
  if (grad.shape() != in.shape || grad.dtype() != in.dtype)
    throw TapeError(std::string(node_.name) + " adjoint: gradient " + grad.describe() + " does not match input " +
                    std::to_string(input) + " " + dtype_name(in.dtype) + in.shape.str());
  if (in.slot >= 0)
    accumulate_into(tape_.slot_grads_[static_cast<std::size_t>(in.slot)], grad);
  else
    accumulate_leaf_grad(*in.leaf, grad);
}

Tensor AdjointContext::accumulation_buffer(std::size_t input) {
  const Tape::InputRef& in = node_.inputs.at(input);
  if (!in.defined || !in.requires_grad) return Tensor();
  if (in.slot < 0) {  // a leaf: other threads may add into its gradient, so add once at the end
    Tensor zeros = Tensor::zeros(in.shape, in.dtype);
    leaf_buffers_.emplace_back(input, zeros);
    return zeros;
  }
  Tensor& g = tape_.slot_grads_[static_cast<std::size_t>(in.slot)];
  if (!g.defined())
    g = Tensor::zeros(in.shape, in.dtype);
  else if (g.impl_ptr().use_count() != 1 || g.impl()->storage.use_count() != 1)  // shared: add into a copy
    g = g.copy();
  return g;
}

void AdjointContext::add_leaf_buffers() {
  for (const auto& [input, buffer] : leaf_buffers_) accumulate_leaf_grad(*node_.inputs.at(input).leaf, buffer);
  leaf_buffers_.clear();
}

// The grad() contract (autodiff/base/tensor.h): every input of a node the sweep ran
// that requires a gradient ends up with one, zeros if the adjoint gave none
// (e.g. a nearest-filter texture's uv). So whether a leaf has a gradient
// depends only on whether the loss depends on it, never on which op it met.
void Tape::give_zero_grads(Node& node) {
  for (const InputRef& in : node.inputs) {
    if (!in.defined || !in.requires_grad) continue;
    if (in.slot >= 0) {
      Tensor& g = slot_grads_[static_cast<std::size_t>(in.slot)];
      if (!g.defined()) g = Tensor::zeros(in.shape, in.dtype);
    } else {
      ensure_leaf_grad(*in.leaf, in.shape, in.dtype);
    }
  }
}

void Tape::check_not_written(const Node& node) const {
  for (std::size_t i = 0; i < node.inputs.size(); ++i) {
    const InputRef& in = node.inputs[i];
    if (in.saved.written())
      throw written_in_place(node.name, "input " + std::to_string(i) + " (" + dtype_name(in.dtype) + in.shape.str() + ")");
  }
  for (std::size_t k = 0; k < node.output_slots.size(); ++k)
    if (output_versions_[static_cast<std::size_t>(node.output_slots[k])].written())
      throw written_in_place(node.name, "output " + std::to_string(k));
}

void Tape::run_backward(const Tensor& output, const Tensor& upstream) {
  if (!output.defined()) throw TapeError("backward: the output tensor is undefined");
  if (!output.requires_grad())
    throw TapeError("backward: the output " + output.describe() +
                    " does not require a gradient (no input of the computation requires grad, or it ran under NoGradGuard)");
  if (upstream.shape() != output.shape() || upstream.dtype() != output.dtype())
    throw TapeError("backward: upstream gradient " + upstream.describe() + " does not match output " + output.describe());
  TensorImpl* out = output.impl();
  if (!out->recorded) {  // a leaf: its gradient is the upstream itself
    accumulate_leaf_grad(*out, upstream);
    return;
  }
  check_recorded_here(*out, "backward: the output");

  NoGradGuard no_grad;  // adjoints compute with ops but record nothing
  slot_grads_.assign(node_of_slot_.size(), Tensor());
  slot_grads_[out->grad_slot] = upstream;
  const std::int64_t start = node_of_slot_[out->grad_slot];
  for (std::int64_t i = start; i >= 0; --i) {
    Node& node = nodes_[i];
    bool has_grad = false;
    for (std::int64_t s : node.output_slots) has_grad |= slot_grads_[s].defined();
    if (has_grad) {
      if (!node.adjoint)
        throw TapeError(std::string("backward: reached '") + node.name +
                        "', whose saved values were freed by an earlier backward(); run the forward computation again");
      check_not_written(node);
      AdjointContext ctx(*this, node);
      node.adjoint(ctx);
      ctx.add_leaf_buffers();
      give_zero_grads(node);
    }
    // Release what the sweep has passed: saved values, inputs, output grads.
    node.adjoint = nullptr;
    node.inputs.clear();
    for (std::int64_t s : node.output_slots) {
      slot_grads_[s] = Tensor();
      output_versions_[s] = SavedVersion();
    }
  }
  // The sweep reached node 0: empty the tape for the next iteration (capacity is
  // kept). Nodes recorded after the output go too (a logged psnr = -10 log(loss)),
  // or a loop that never backpropagates them would grow the tape without bound.
  clear();
}

void backward(const Tensor& output, const Tensor& upstream_grad) {
  Tape::current().run_backward(output, upstream_grad);
}

void backward(const Tensor& loss) {
  if (!loss.defined()) throw TapeError("backward: the loss tensor is undefined");
  if (loss.numel() != 1)
    throw TapeError("backward: the loss has shape " + loss.shape().str() +
                    "; a loss must have one element (or pass an upstream gradient of that shape)");
  Tensor seed = Tensor::ones(loss.shape(), loss.dtype());
  backward(loss, seed);
}

}  // namespace gr
