#include "ops/tensor/map_rows.h"

#include <cstring>
#include <optional>
#include <string>

#include "autodiff/base/parallel.h"
#include "autodiff/base/storage.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/check.h"
#include "ops/tensor/fused_rows.h"
#include "ops/tensor/fused_rows_program.h"
#include "ops/tensor/reduce.h"

namespace gr {
namespace {

constexpr const char* kOp = "map_rows";
constexpr std::int64_t kAutoBlockPixels = 4096;

// Bytes of one row (everything after the leading axis).
std::size_t row_bytes(const Shape& shape, DType dtype) {
  const std::int64_t n = shape[0];
  return n == 0 ? 0 : static_cast<std::size_t>(shape.numel() / n) * dtype_size(dtype);
}

Shape with_rows(const Shape& shape, std::int64_t rows) {
  std::vector<std::int64_t> dims = shape.dims();
  dims[0] = rows;
  return Shape(dims);
}

char* bytes(const Tensor& t) { return static_cast<char*>(t.impl()->storage->data()); }

// A new tensor holding rows [lo, hi) of t.
Tensor copy_rows(const Tensor& t, std::int64_t lo, std::int64_t hi) {
  Tensor out = Tensor::empty(with_rows(t.shape(), hi - lo), t.dtype());
  const std::size_t rb = row_bytes(t.shape(), t.dtype());
  if (hi > lo) std::memcpy(bytes(out), bytes(t) + lo * rb, (hi - lo) * rb);
  return out;
}

// Writes `block` (rows [lo, hi) of dst's shape) into dst.
void write_rows(Tensor& dst, const Tensor& block, std::int64_t lo, std::int64_t hi) {
  const std::size_t rb = row_bytes(dst.shape(), dst.dtype());
  if (hi > lo) std::memcpy(bytes(dst) + lo * rb, bytes(block), (hi - lo) * rb);
}

void zero_rows(Tensor& dst, std::int64_t lo, std::int64_t hi) {
  const std::size_t rb = row_bytes(dst.shape(), dst.dtype());
  if (hi > lo) std::memset(bytes(dst) + lo * rb, 0, (hi - lo) * rb);
}

// f's output for rows [lo, hi): [hi - lo, ...], floating, and (when `like` is
// defined) of like's trailing shape and dtype.
void check_block_output(const Tensor& out, std::int64_t lo, std::int64_t hi, const Tensor& like) {
  const std::string block = "f's output for rows [" + std::to_string(lo) + ", " + std::to_string(hi) + ")";
  if (!out.defined()) throw ValueError(std::string(kOp) + ": " + block + " is undefined");
  if (out.rank() < 1 || out.size(0) != hi - lo)
    throw ShapeError(std::string(kOp) + ": " + block + " has shape " + out.shape().str() + "; f must return one row per input row (" +
                     std::to_string(hi - lo) + "), so no reduction over rows inside f");
  detail::check_float(out, kOp, "f's output");
  if (like.defined() && (with_rows(out.shape(), like.size(0)) != like.shape() || out.dtype() != like.dtype()))
    throw ShapeError(std::string(kOp) + ": " + block + " is " + out.describe() + ", but the first block's was " +
                     like.describe() + "; every block must give the same row shape and dtype");
}

struct Blocks {
  std::int64_t rows, size, count;
  std::int64_t lo(std::int64_t b) const { return b * size; }
  std::int64_t hi(std::int64_t b) const { return std::min(rows, b * size + size); }
};

// Pixels in one row of rows[0] (the product of its axes but the first and the
// last; 1 for [N, C]), at least 1.
std::int64_t pixels_per_row(const std::vector<Tensor>& rows) {
  const Tensor& r = rows[0];
  const std::int64_t n = r.size(0);
  const std::int64_t pixels = r.rank() >= 2 && n > 0 && r.size(-1) > 0 ? r.numel() / (n * r.size(-1)) : 1;
  return std::max<std::int64_t>(1, pixels);
}

// Inputs of block b: copies of its rows, and the shared inputs (as given, or
// as fresh leaves requiring grad when `leaves` is set).
std::vector<Tensor> block_rows(const std::vector<Tensor>& rows, const Blocks& blocks, std::int64_t b, bool leaves) {
  std::vector<Tensor> out;
  out.reserve(rows.size());
  for (const Tensor& r : rows) {
    Tensor block = copy_rows(r, blocks.lo(b), blocks.hi(b));
    if (leaves && r.requires_grad()) block.set_requires_grad();
    out.push_back(block);
  }
  return out;
}

std::vector<Tensor> block_shared(const std::vector<Tensor>& shared, bool leaves) {
  std::vector<Tensor> out;
  out.reserve(shared.size());
  for (const Tensor& s : shared) {
    Tensor leaf = s.defined() ? s.detach() : Tensor();
    if (leaves && s.defined() && s.requires_grad()) leaf.set_requires_grad();
    out.push_back(leaf);
  }
  return out;
}

// f's trace: f called on the first `rows` rows of block 0 (the trace block),
// and its fused program (null if f is not replayable or fusion is off). The
// trace block is the first rows holding at least kTraceLanes pixels (or all of
// block 0): f's ops cost per call plus per pixel, and the fused interpreter
// replays the per-pixel part faster, so the whole of block 0 was paid twice
// over at small sizes (issue 31). With gradients on, the block runs on a private tape with the
// inputs needing a gradient as leaves, so a value f computes from them by an
// op the trace does not know is never taken for a constant.
constexpr std::int64_t kTraceLanes = detail::kLanes;  // one chunk of the interpreter

struct Probe {
  Tensor first;       // f's output for the trace block (detached)
  std::int64_t rows;  // the trace block's rows
  std::shared_ptr<const detail::FusedRows> fused;
};

// Rows of the trace block: enough for kTraceLanes pixels, within block 0.
std::int64_t trace_rows(const std::vector<Tensor>& rows, const Blocks& blocks) {
  const std::int64_t per_row = pixels_per_row(rows);
  return std::min(blocks.count == 0 ? 0 : blocks.hi(0), (kTraceLanes + per_row - 1) / per_row);
}

Probe probe(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared, const Blocks& blocks,
            bool fuse) {
  std::optional<ScopedTape> tape;
  std::optional<NoGradGuard> no_grad;
  if (grad_mode_enabled())
    tape.emplace();
  else
    no_grad.emplace();
  Probe p;
  p.rows = trace_rows(rows, blocks);
  const Blocks trace_block{p.rows, p.rows, 1};
  const std::vector<Tensor> r0 = block_rows(rows, trace_block, 0, true), s0 = block_shared(shared, true);
  detail::FusionTrace trace;
  try {
    p.first = f(r0, s0);
  } catch (const TapeError& e) {
    throw TapeError(std::string(kOp) + ": f used a recorded tensor it captured; pass it in `rows` or `shared` (" +
                    e.what() + ")");
  }
  check_block_output(p.first, 0, p.rows, Tensor());
  if (fuse) {
    std::vector<bool> rows_grad, shared_grad;
    for (const Tensor& r : rows) rows_grad.push_back(r.requires_grad());
    for (const Tensor& t : shared) shared_grad.push_back(t.defined() && t.requires_grad());
    p.fused = detail::FusedRows::compile(trace, r0, s0, p.first, rows_grad, shared_grad);
  }
  p.first = p.first.detach();
  return p;
}

Blocks check_inputs(const RowFunction& f, const std::vector<Tensor>& rows, const MapRowsOptions& options) {
  if (!f) throw ValueError(std::string(kOp) + ": f is empty");
  if (options.block_rows < 0)
    throw ValueError(std::string(kOp) + ": block_rows must be at least 1 (or 0: automatic), got " +
                     std::to_string(options.block_rows));
  if (rows.empty()) throw ValueError(std::string(kOp) + ": rows is empty; give at least one [N, ...] input");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::string name = "rows[" + std::to_string(i) + "]";
    detail::check_defined(rows[i], kOp, name.c_str());
    if (rows[i].rank() < 1) throw ShapeError(std::string(kOp) + ": " + name + " is a scalar; rows need a leading axis");
    if (rows[i].size(0) != rows[0].size(0))
      throw ShapeError(std::string(kOp) + ": " + name + " has " + std::to_string(rows[i].size(0)) +
                       " rows but rows[0] has " + std::to_string(rows[0].size(0)));
  }
  const std::int64_t n = rows[0].size(0);
  std::int64_t size = options.block_rows;
  if (size == 0) size = std::max<std::int64_t>(1, kAutoBlockPixels / pixels_per_row(rows));  // about 4096 pixels
  return Blocks{n, size, (n + size - 1) / size};
}

// map_rows once f's trace has run (probe): its output is block 0's when the
// trace block was all of block 0; the other blocks (or all) run now.
Tensor map_rows_probed(const Probe& p, const RowFunction& f, const std::vector<Tensor>& rows,
                       const std::vector<Tensor>& shared, const Blocks& blocks) {
  const std::int64_t n = blocks.rows;
  const std::shared_ptr<const detail::FusedRows> fused = p.fused;
  Tensor out = Tensor::empty(with_rows(p.first.shape(), n), p.first.dtype());
  const bool first_done = blocks.count == 0 || p.rows == blocks.hi(0);
  if (first_done) write_rows(out, p.first, 0, p.rows);
  parallel_for(first_done ? 1 : 0, blocks.count, 1, [&](std::int64_t b0, std::int64_t b1) {
    if (fused) {
      fused->forward(rows, out, blocks.lo(b0), blocks.hi(b1 - 1));
      return;
    }
    NoGradGuard no_grad;  // grad mode is per thread
    for (std::int64_t b = b0; b < b1; ++b) {
      Tensor block = f(block_rows(rows, blocks, b, false), block_shared(shared, false));
      check_block_output(block, blocks.lo(b), blocks.hi(b), p.first);
      write_rows(out, block, blocks.lo(b), blocks.hi(b));
    }
  });

  std::vector<Tensor> inputs(rows);
  inputs.insert(inputs.end(), shared.begin(), shared.end());
  if (!should_record(inputs)) return out;
  record(kOp, inputs, {&out}, [f, rows, shared, blocks, fused](AdjointContext& ctx) {
    const Tensor& g = ctx.grad_output();
    if (!g.defined()) return;
    const std::size_t nr = rows.size(), ns = shared.size();
    std::vector<Tensor> row_grads(nr);
    for (std::size_t i = 0; i < nr; ++i)
      if (ctx.needs_grad(i)) row_grads[i] = Tensor::empty(rows[i].shape(), rows[i].dtype());
    // shared_grads[b * ns + j]: block b's gradient of shared input j (undefined: none).
    std::vector<Tensor> shared_grads(static_cast<std::size_t>(blocks.count) * ns);
    parallel_for(0, blocks.count, 1, [&](std::int64_t b0, std::int64_t b1) {
      for (std::int64_t b = b0; b < b1; ++b) {
        const std::int64_t lo = blocks.lo(b), hi = blocks.hi(b);
        if (fused) {
          const std::vector<Tensor> s = fused->backward(rows, g, row_grads, lo, hi);
          for (std::size_t j = 0; j < ns; ++j)
            if (ctx.needs_grad(nr + j)) shared_grads[b * ns + j] = s[j];
          continue;
        }
        ScopedTape tape;  // the block's graph, recomputed (checkpointing)
        std::vector<Tensor> r = block_rows(rows, blocks, b, true), s = block_shared(shared, true);
        Tensor block = f(r, s);
        if (block.requires_grad()) backward(block, copy_rows(g, lo, hi));
        for (std::size_t i = 0; i < nr; ++i) {
          if (!row_grads[i].defined()) continue;
          if (r[i].has_grad())
            write_rows(row_grads[i], r[i].grad(), lo, hi);
          else
            zero_rows(row_grads[i], lo, hi);
        }
        for (std::size_t j = 0; j < ns; ++j)
          if (ctx.needs_grad(nr + j) && s[j].has_grad()) shared_grads[b * ns + j] = s[j].grad();
      }
    });
    for (std::size_t i = 0; i < nr; ++i)
      if (row_grads[i].defined()) ctx.accumulate(i, row_grads[i]);
    // Shared gradients: summed over blocks in block order (thread-count independent).
    for (std::size_t j = 0; j < ns; ++j) {
      if (!ctx.needs_grad(nr + j)) continue;
      for (std::int64_t b = 0; b < blocks.count; ++b)
        if (shared_grads[b * ns + j].defined()) ctx.accumulate(nr + j, shared_grads[b * ns + j]);
    }
  });
  return out;
}

}  // namespace

Tensor map_rows(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared,
                const MapRowsOptions& options) {
  const Blocks blocks = check_inputs(f, rows, options);
  // Block 0 (or the empty input) first, eagerly: it fixes the output's shape,
  // and f's trace on it becomes the fused program (ops/tensor/fused_rows.h) the
  // other blocks run, when every op f used can be replayed.
  return map_rows_probed(probe(f, rows, shared, blocks, options.fuse), f, rows, shared, blocks);
}

bool map_rows_fuses(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared,
                    const MapRowsOptions& options) {
  const Blocks blocks = check_inputs(f, rows, options);
  return probe(f, rows, shared, blocks, options.fuse).fused != nullptr;
}

Tensor map_rows_mean(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared,
                     const MapRowsOptions& options) {
  const Blocks blocks = check_inputs(f, rows, options);
  const Probe p = probe(f, rows, shared, blocks, options.fuse);
  std::vector<Tensor> inputs(rows);
  inputs.insert(inputs.end(), shared.begin(), shared.end());
  // The loss's sum runs (reduce's kSumBlock elements) must start with blocks:
  // true for the automatic block size; otherwise two passes, as mean(map_rows).
  const std::int64_t per_row = p.first.size(0) > 0 ? p.first.numel() / p.first.size(0) : 0;
  const bool aligned = per_row > 0 && (blocks.size * per_row) % detail::kSumBlock == 0;
  if (!p.fused || !aligned || !should_record(inputs)) return mean(map_rows_probed(p, f, rows, shared, blocks));
  const std::shared_ptr<const detail::FusedRows> fused = p.fused;
  const DType dtype = p.first.dtype();
  const std::int64_t count = blocks.rows * per_row, runs_per_block = blocks.size * per_row / detail::kSumBlock;
  // mean(e) = sum(e) * T(1 / count): its adjoint gives every element of e the
  // upstream gradient times T(1 / count), which for the usual upstream 1 is
  // T(1 / count) itself. The gradients for it are computed with the values.
  auto element_grad = [dtype, count](double upstream) {
    return dtype == DType::Float32 ? double(float(upstream) * float(1 / double(count)))
                                   : upstream * (1 / double(count));
  };
  // Row gradients and per-block shared ones for upstream `seed` (and e's run sums, when given).
  struct Grads {
    std::vector<Tensor> rows, shared_per_block;
  };
  auto gradients = [rows, shared, blocks, fused, runs_per_block](double seed, double* sums) {
    const std::size_t ns = shared.size();
    Grads g{std::vector<Tensor>(rows.size()), std::vector<Tensor>(std::size_t(blocks.count) * ns)};
    for (std::size_t i = 0; i < rows.size(); ++i)
      if (rows[i].requires_grad()) g.rows[i] = Tensor::empty(rows[i].shape(), rows[i].dtype());
    parallel_for(0, blocks.count, 1, [&](std::int64_t b0, std::int64_t b1) {
      for (std::int64_t b = b0; b < b1; ++b) {
        const std::vector<Tensor> s = fused->backward_uniform(rows, seed, g.rows, blocks.lo(b), blocks.hi(b),
                                                              sums ? sums + b * runs_per_block : nullptr);
        for (std::size_t j = 0; j < ns; ++j) g.shared_per_block[std::size_t(b) * ns + j] = s[j];
      }
    });
    return g;
  };
  std::vector<double> sums(std::size_t((count + detail::kSumBlock - 1) / detail::kSumBlock));
  const Grads at_one = gradients(element_grad(1.0), sums.data());
  // The loss as mean(e) computes it: the runs added in order, rounded, times T(1 / count).
  double total = 0;
  for (double run : sums) total += run;
  Tensor loss = Tensor::scalar(dtype == DType::Float32 ? double(float(total) * float(1 / double(count)))
                                                       : total * (1 / double(count)),
                               dtype);
  record("map_rows_mean", inputs, {&loss}, [at_one, gradients, element_grad, nr = rows.size(), ns = shared.size(),
                                            blocks = blocks.count](AdjointContext& ctx) {
    const Tensor& upstream = ctx.grad_output();
    if (!upstream.defined()) return;
    // Upstream 1: the gradients computed with the values; another (a weighted loss): computed again.
    const Grads g = upstream.item() == 1.0 ? at_one : gradients(element_grad(upstream.item()), nullptr);
    for (std::size_t i = 0; i < nr; ++i)
      if (g.rows[i].defined()) ctx.accumulate(i, g.rows[i]);
    // Shared inputs: summed over blocks in block order (any thread count).
    for (std::size_t j = 0; j < ns; ++j)
      for (std::int64_t b = 0; b < blocks; ++b) {
        const Tensor& t = g.shared_per_block[std::size_t(b) * ns + j];
        if (ctx.needs_grad(nr + j) && t.defined()) ctx.accumulate(nr + j, t);
      }
  });
  return loss;
}

}  // namespace gr
