// Blocked evaluation of a row-wise function (issue 17, docs/map_rows.md): the
// user's shading code, written with ordinary tensor ops, runs over blocks of
// rows small enough to stay in cache, and its graph is never stored whole.
//
//   Tensor colour = map_rows([&](const std::vector<Tensor>& r, const std::vector<Tensor>& s) {
//     Tensor l = normalize(s[0] - r[0]);                 // s[0] = light [3]
//     return r[1] * maximum(dot(r[2], l), 0.0);          // r = {p, albedo, n}, [N, 3] each
//   }, {p, albedo, n}, {light});
//
// Rows are split along the first axis: [N, C] inputs into pixels, an image's
// [H, W, C] into rows of pixels (the fused interpreter then works on pixels).
//
// Forward: f runs on the trace block (copies of the first rows of every `rows`
// input holding 256 pixels, or all of the first block of block_rows rows if
// that is less; the `shared` inputs whole) while its ops are traced.
// When every op f used can be replayed (ops/tensor/fused_rows.h: the arithmetic
// ops, minimum/maximum, pow with a number, dot and normalize, on rows, columns,
// shared vectors and constants), every block runs that trace through the
// fused interpreter: one pass over the inputs in chunks of 256 pixels held in
// cache, forward and, in the adjoint, forward again and backward. Otherwise f
// is called on each block, without recording, blocks in parallel, and its
// adjoint runs f again per block on a private tape (checkpointing: recompute
// instead of store). Either way map_rows records one node, writes the rows'
// gradients in place and sums the shared inputs' gradients over blocks in
// block order.
//
// f must be row-wise (output row i depends only on row i of each `rows` input
// and on the shared inputs), return one row per input row, do the same ops on
// every block (no branching on values or on the block's size: the trace of
// the trace block stands for all), and be safe to call from several threads
// at once. Then the output, and the gradients of the `rows` inputs, are
// bit-identical to calling f on the whole inputs, fused or not; the shared
// inputs' gradients are summed per block and then over blocks in order, so
// they are the same for any thread count and equal to the unblocked graph's
// up to rounding. Every differentiable value must enter f through `rows` or
// `shared`: a recorded tensor captured by f throws TapeError. Small tensors f
// creates itself (at most 64 elements, such as 0.5 or a fixed direction) are
// constants, taken from the trace block's call.
#pragma once

#include <functional>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

using RowFunction = std::function<Tensor(const std::vector<Tensor>& rows, const std::vector<Tensor>& shared)>;

struct MapRowsOptions {
  // Rows per block; 0: about 4096 pixels per block (4096 rows of [N, C]
  // inputs, 4096 / W rows of an image's [H, W, C]), which keeps a block's
  // dozen float32 intermediates within a core's L2 cache when f runs per
  // block and gives the threads enough blocks to share.
  std::int64_t block_rows = 0;
  // Replay f's trace with the fused interpreter (ops/tensor/fused_rows.h) when every
  // op it used can be replayed; false: call f per block as well.
  bool fuse = true;
};

// rows: defined tensors of rank >= 1 sharing their leading size N; shared: any
// tensors (undefined allowed). Throws ValueError / ShapeError naming the input
// for a bad block size, rows of different lengths, or an f whose output for a
// block is not [block rows, ...] of one shape and float dtype.
Tensor map_rows(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared = {},
                const MapRowsOptions& options = {});

// mean(map_rows(f, rows, shared, options)), the same bits, for a loss: when f
// is fused, its forward, the loss's sum and the backward run in one pass at
// the call (an upstream gradient of 1, the usual loss, then uses them; any
// other is computed again in the backward), so f's inputs are read once and
// f's output is never stored. Holds the rows' gradients until the backward.
// (With a block size whose blocks do not start reduce's runs of 4096 output
// elements, or without gradients, it is mean(map_rows(...)).)
Tensor map_rows_mean(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared = {},
                     const MapRowsOptions& options = {});

// Whether map_rows(f, rows, shared, options) would run the fused interpreter
// (it calls f once on the trace block, without recording on the thread's tape).
bool map_rows_fuses(const RowFunction& f, const std::vector<Tensor>& rows, const std::vector<Tensor>& shared = {},
                    const MapRowsOptions& options = {});

}  // namespace gr
