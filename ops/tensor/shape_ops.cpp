// Ops that move elements without arithmetic (reshape, slice, concat, stack,
// gather, scatter_add), forward kernels and adjoints side by side.
//
// All of them work on float32, float64 and int32 tensors; only float inputs
// get gradients. Every kernel writes each output element from one thread.
// scatter_add (and gather's adjoint, which is a scatter_add) sums duplicate
// indices in ascending source order through a CSR table built serially, so
// the result is bit-identical for any thread count.
#include "ops/tensor/shape_ops.h"

#include <algorithm>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/tensor/small_count.h"

namespace gr {
namespace {

// Calls f(T{}) for the element type of `t`.
template <class F>
void dispatch_any(DType t, F&& f) {
  switch (t) {
    case DType::Float32: f(float{}); break;
    case DType::Float64: f(double{}); break;
    case DType::Int32: f(std::int32_t{}); break;
  }
}

void check_defined(const Tensor& t, const std::string& op, const std::string& name) {
  if (!t.defined()) throw ValueError(op + ": argument '" + name + "' is an undefined tensor");
}

// Rows per parallel chunk when each row moves `inner` elements.
std::int64_t copy_grain(std::int64_t inner) {
  return std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, inner));
}

// For r in [lo, hi): copies `len` elements from src_of(r) to dst_of(r). Runs
// of 1-4 elements (image channels, xyz rows) get a loop of fixed length: no
// library call and no division per element.
template <class SrcOf, class DstOf>
void copy_rows(std::int64_t len, std::int64_t lo, std::int64_t hi, SrcOf src_of, DstOf dst_of) {
  auto fixed = [&](auto length) {
    constexpr int L = decltype(length)::value;
    for (std::int64_t r = lo; r < hi; ++r) {
      const auto* s = src_of(r);
      auto* d = dst_of(r);
      for (int k = 0; k < L; ++k) d[k] = s[k];
    }
  };
  switch (len) {
    case 0: return;
    case 1: return fixed(std::integral_constant<int, 1>());
    case 2: return fixed(std::integral_constant<int, 2>());
    case 3: return fixed(std::integral_constant<int, 3>());
    case 4: return fixed(std::integral_constant<int, 4>());
    default:
      for (std::int64_t r = lo; r < hi; ++r) std::copy_n(src_of(r), len, dst_of(r));
  }
}

// The row moves of slice: row (q, j) of the result, viewed as [outer, count,
// inner], is row (q, first + j step) of a, viewed as [outer, n, inner].
struct SliceRows {
  std::int64_t outer, n, count, inner, first, step;
  std::int64_t a_row(std::int64_t q, std::int64_t j) const { return (q * n + first + j * step) * inner; }
  std::int64_t out_row(std::int64_t q, std::int64_t j) const { return (q * count + j) * inner; }

  // Copies every picked row from src to dst: a -> result, or with kIntoA
  // result -> a (the adjoint), zeroing a's other rows. Parallel over blocks of
  // q (step 1: one run of count * inner elements per q) when there are as many
  // q as j or enough for 4 chunks on 16 threads, else over j (slices along
  // axis 0 have one q). No division per element.
  template <bool kIntoA, class T>
  void move(const T* src, T* dst) const {
    auto from = [=](std::int64_t q, std::int64_t j) { return src + (kIntoA ? out_row(q, j) : a_row(q, j)); };
    auto to = [=](std::int64_t q, std::int64_t j) { return dst + (kIntoA ? a_row(q, j) : out_row(q, j)); };
    const std::int64_t picked = count * inner, block = n * inner;
    if (picked > 0 && (outer >= count || outer >= 64)) {
      parallel_for(0, outer, copy_grain(kIntoA ? block : picked), [&](std::int64_t lo, std::int64_t hi) {
        if (kIntoA) std::fill(dst + lo * block, dst + hi * block, T(0));
        if (step == 1) {
          copy_rows(picked, lo, hi, [&](std::int64_t q) { return from(q, 0); },
                    [&](std::int64_t q) { return to(q, 0); });
          return;
        }
        for (std::int64_t q = lo; q < hi; ++q)
          copy_rows(inner, 0, count, [&](std::int64_t j) { return from(q, j); },
                    [&](std::int64_t j) { return to(q, j); });
      });
      return;
    }
    // No q loop at all for an empty result (a [2^31, 7, 0, 0] slice must not walk 2^31 empty blocks).
    if (kIntoA && block > 0)
      parallel_for(0, outer * block, kElementwiseGrain,
                   [&](std::int64_t lo, std::int64_t hi) { std::fill(dst + lo, dst + hi, T(0)); });
    for (std::int64_t q = 0; picked > 0 && q < outer; ++q)
      parallel_for(0, count, copy_grain(inner), [&](std::int64_t j0, std::int64_t j1) {
        copy_rows(inner, j0, j1, [&](std::int64_t j) { return from(q, j); }, [&](std::int64_t j) { return to(q, j); });
      });
  }
};

// A tensor sharing t's storage under another shape (not recorded).
Tensor view_as(const Tensor& t, const Shape& shape) {
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = shape;
  impl->dtype = t.dtype();
  impl->storage = t.impl()->storage;
  return Tensor(std::move(impl));
}

std::string vec_str(const std::vector<std::int64_t>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}

// Product of dims [from, to).
std::int64_t prod(const Shape& s, int from, int to) {
  std::int64_t p = 1;
  for (int i = from; i < to; ++i) p *= s[i];
  return p;
}

// --- join / split: the kernels of concat and stack -------------------------
// The output is viewed as [outer, total] and input i as [outer, chunk_i],
// placed at column offset_i.

void join_raw(const std::vector<Tensor>& parts, const std::vector<std::int64_t>& chunk, std::int64_t outer,
              Tensor& out) {
  const std::int64_t total = out.numel() / std::max<std::int64_t>(1, outer);
  dispatch_any(out.dtype(), [&](auto tag) {
    using T = decltype(tag);
    T* o = out.data<T>();
    // out[r, offset_i : offset_i + c_i] = part_i[r, :], every part for a block of rows at a time.
    parallel_for(0, total == 0 ? 0 : outer, copy_grain(total), [&](std::int64_t lo, std::int64_t hi) {
      std::int64_t offset = 0;
      for (std::size_t i = 0; i < parts.size(); ++i) {
        const T* src = std::as_const(parts[i]).data<T>();
        const std::int64_t c = chunk[i];
        copy_rows(c, lo, hi, [=](std::int64_t r) { return src + r * c; },
                  [=](std::int64_t r) { return o + r * total + offset; });
        offset += c;
      }
    });
  });
}

// The parts [outer, chunk_i] of g (viewed as [outer, total]) that `wanted`
// marks, with shapes `shapes`, in one pass over g's rows; undefined for the others.
std::vector<Tensor> split_raw(const Tensor& g, std::int64_t outer, const std::vector<std::int64_t>& chunk,
                              const std::vector<bool>& wanted, const std::vector<Shape>& shapes) {
  std::vector<Tensor> parts(chunk.size());
  for (std::size_t i = 0; i < chunk.size(); ++i)
    if (wanted[i]) parts[i] = Tensor::empty(shapes[i], g.dtype());
  const std::int64_t total = g.numel() / std::max<std::int64_t>(1, outer);
  dispatch_any(g.dtype(), [&](auto tag) {
    using T = decltype(tag);
    const T* src = g.data<T>();
    // part_i[r, :] = g[r, offset_i : offset_i + c_i].
    parallel_for(0, total == 0 ? 0 : outer, copy_grain(total), [&](std::int64_t lo, std::int64_t hi) {
      std::int64_t offset = 0;
      for (std::size_t i = 0; i < parts.size(); ++i) {
        const std::int64_t c = chunk[i];
        if (parts[i].defined()) {
          T* o = parts[i].data<T>();
          copy_rows(c, lo, hi, [=](std::int64_t r) { return src + r * total + offset; },
                    [=](std::int64_t r) { return o + r * c; });
        }
        offset += c;
      }
    });
  });
  return parts;
}

// Shared by concat and stack: joins `parts` (already validated) into `out_shape`
// and records the split adjoint.
Tensor join(const char* name, const std::vector<Tensor>& parts, const std::vector<std::int64_t>& chunk,
            std::int64_t outer, const Shape& out_shape) {
  Tensor out = Tensor::empty(out_shape, parts[0].dtype());
  join_raw(parts, chunk, outer, out);
  if (is_floating(out.dtype()) && should_record(parts)) {
    record(name, parts, {&out}, [chunk, outer](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/d part_i = the columns of g that part_i filled.
      std::vector<bool> wanted(chunk.size());
      std::vector<Shape> shapes(chunk.size());
      for (std::size_t i = 0; i < chunk.size(); ++i) wanted[i] = ctx.needs_grad(i), shapes[i] = ctx.input_shape(i);
      const std::vector<Tensor> parts = split_raw(g, outer, chunk, wanted, shapes);
      for (std::size_t i = 0; i < chunk.size(); ++i)
        if (wanted[i]) ctx.accumulate(i, parts[i]);
    });
  }
  return out;
}

// --- gather / scatter -------------------------------------------------------

// Throws unless `index` is int32 with every value in [0, rows).
void check_index(const Tensor& index, std::int64_t rows, const std::string& op, const std::string& range_what) {
  check_defined(index, op, "index");
  if (index.dtype() != DType::Int32)
    throw DTypeError(op + ": argument 'index' must be int32, got " + index.describe());
  const std::int32_t* idx = index.data<std::int32_t>();
  const std::int64_t n = index.numel();
  for (std::int64_t i = 0; i < n; ++i)
    if (idx[i] < 0 || idx[i] >= rows)
      throw IndexError(op + ": index element " + std::to_string(i) + " is " + std::to_string(idx[i]) +
                       ", outside [0, " + std::to_string(rows) + ") (" + range_what + ")");
}

// out[i, :] = src[idx[i], :] for n rows of `inner` elements.
template <class T>
void gather_rows(const T* src, const std::int32_t* idx, T* out, std::int64_t n, std::int64_t inner) {
  parallel_for(0, n, copy_grain(inner), [&](std::int64_t lo, std::int64_t hi) {
    copy_rows(inner, lo, hi, [=](std::int64_t i) { return src + idx[i] * inner; },
              [=](std::int64_t i) { return out + i * inner; });
  });
}

// out[r, :] = sum of src[i, :] over i with idx[i] == r, in ascending i, for
// `rows` rows of `inner` elements (out is overwritten).
template <class T>
void scatter_rows(const T* src, const std::int32_t* idx, T* out, std::int64_t n, std::int64_t rows, std::int64_t inner) {
  std::fill(out, out + rows * inner, T(0));
  if (n * inner <= kElementwiseGrain) {
    // Small: one serial pass in ascending source order.
    return detail::with_small_count(inner, [=](auto length) {
      for (std::int64_t i = 0; i < n; ++i) {
        T* o = out + idx[i] * length;
        const T* s = src + i * length;
        for (std::int64_t j = 0; j < length; ++j) o[j] += s[j];
      }
    });
  }
  // CSR of target row -> source rows, each list in ascending source order.
  std::vector<std::int64_t> start(static_cast<std::size_t>(rows + 1), 0);
  for (std::int64_t i = 0; i < n; ++i) ++start[static_cast<std::size_t>(idx[i] + 1)];
  for (std::int64_t r = 0; r < rows; ++r) start[r + 1] += start[r];
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  std::vector<std::int64_t> order(static_cast<std::size_t>(n));
  for (std::int64_t i = 0; i < n; ++i) order[static_cast<std::size_t>(fill[idx[i]]++)] = i;
  // Each target row sums its sources in list order: same result for any thread count.
  const std::int64_t per_row = (n + rows - 1) / std::max<std::int64_t>(1, rows) + 1;
  parallel_for(0, rows, copy_grain(per_row * inner), [&](std::int64_t lo, std::int64_t hi) {
    detail::with_small_count(inner, [&](auto length) {
      for (std::int64_t r = lo; r < hi; ++r) {
        T* o = out + r * length;
        for (std::int64_t e = start[r]; e < start[r + 1]; ++e) {
          const T* s = src + order[static_cast<std::size_t>(e)] * length;
          for (std::int64_t j = 0; j < length; ++j) o[j] += s[j];
        }
      }
    });
  });
}

// Gathers rows of `src` (viewed as [rows, inner]) into a tensor of `shape`.
Tensor gather_raw(const Tensor& src, const Tensor& index, std::int64_t inner, const Shape& shape) {
  Tensor out = Tensor::empty(shape, src.dtype());
  dispatch_any(src.dtype(), [&](auto tag) {
    using T = decltype(tag);
    gather_rows(src.data<T>(), index.data<std::int32_t>(), out.data<T>(), index.numel(), inner);
  });
  return out;
}

// Scatter-adds rows of `src` (viewed as [index.numel, inner]) into a zero tensor of `shape`.
Tensor scatter_raw(const Tensor& src, const Tensor& index, std::int64_t rows, std::int64_t inner, const Shape& shape) {
  Tensor out = Tensor::empty(shape, src.dtype());
  dispatch_any(src.dtype(), [&](auto tag) {
    using T = decltype(tag);
    scatter_rows(src.data<T>(), index.data<std::int32_t>(), out.data<T>(), index.numel(), rows, inner);
  });
  return out;
}

}  // namespace

Tensor reshape(const Tensor& a, const std::vector<std::int64_t>& shape) {
  check_defined(a, "reshape", "a");
  if (shape.size() > static_cast<std::size_t>(Shape::kMaxRank))
    throw ShapeError("reshape: target shape " + vec_str(shape) + " has rank " + std::to_string(shape.size()) +
                     " (at most 4 supported)");
  // Resolve the one -1 extent from the element count.
  std::vector<std::int64_t> dims = shape;
  int infer = -1;
  std::int64_t known = 1;
  for (std::size_t i = 0; i < dims.size(); ++i) {
    if (dims[i] == -1) {
      if (infer >= 0)
        throw ShapeError("reshape: target shape " + vec_str(shape) + " has more than one -1 extent");
      infer = static_cast<int>(i);
    } else if (dims[i] < 0) {
      throw ShapeError("reshape: target shape " + vec_str(shape) + " has a negative extent");
    } else {
      known = multiply_extents(known, dims[i], "reshape: target shape " + vec_str(shape));
    }
  }
  if (infer >= 0) {
    if (known == 0 || a.numel() % known != 0)
      throw ShapeError("reshape: cannot reshape " + a.describe() + " (" + std::to_string(a.numel()) +
                       " elements) into " + vec_str(shape));
    dims[static_cast<std::size_t>(infer)] = a.numel() / known;
  } else if (known != a.numel()) {
    throw ShapeError("reshape: cannot reshape " + a.describe() + " (" + std::to_string(a.numel()) +
                     " elements) into " + vec_str(shape) + " (" + std::to_string(known) + " elements)");
  }
  // Same storage, new shape.
  Tensor out = view_as(a, Shape(dims));
  if (is_floating(a.dtype()) && should_record({a})) {
    record("reshape", {a}, {&out}, [](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/da = g viewed in a's shape.
      ctx.accumulate(0, view_as(g, ctx.input_shape(0)));
    });
  }
  return out;
}

Tensor slice(const Tensor& a, int axis, std::int64_t start, std::int64_t stop, std::int64_t step) {
  check_defined(a, "slice", "a");
  if (a.rank() < 1) throw ShapeError("slice: argument 'a' must have at least one axis, got " + a.describe());
  const int ax = a.shape().normalize_axis(axis, "slice: axis");
  if (step == 0) throw ValueError("slice: step must not be 0");
  // Python slice semantics: negative bounds count from the end, then clamp.
  const std::int64_t n = a.size(ax);
  const std::int64_t lower = step > 0 ? 0 : -1, upper = step > 0 ? n : n - 1;
  auto clamp_bound = [&](std::int64_t v) {
    if (v < 0) {
      v = v < -n ? lower : v + n;
      return std::max(v, lower);
    }
    return std::min(v, upper);
  };
  const std::int64_t first = clamp_bound(start), last = clamp_bound(stop);
  std::int64_t count = 0;
  if (step > 0 && last > first) count = (last - first + step - 1) / step;
  if (step < 0 && first > last) count = (first - last - step - 1) / (-step);
  std::vector<std::int64_t> d = a.shape().dims();
  d[static_cast<std::size_t>(ax)] = count;
  const Shape out_shape(d);
  const std::int64_t outer = prod(a.shape(), 0, ax), inner = prod(a.shape(), ax + 1, a.rank());
  const SliceRows rows{outer, n, count, inner, first, step};
  Tensor out = Tensor::empty(out_shape, a.dtype());
  dispatch_any(a.dtype(), [&](auto tag) {
    using T = decltype(tag);
    // out[q, j, :] = a[q, first + j step, :].
    rows.move<false>(std::as_const(a).data<T>(), out.data<T>());
  });
  if (is_floating(a.dtype()) && should_record({a})) {
    record("slice", {a}, {&out}, [rows](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor ga = Tensor::empty(ctx.input_shape(0), g.dtype());
      dispatch_float(g.dtype(), "slice", [&](auto tag) {
        using T = decltype(tag);
        // dL/da[q, first + j step, :] = g[q, j, :] (the picked rows are distinct), 0 elsewhere.
        rows.move<true>(g.data<T>(), ga.data<T>());
      });
      ctx.accumulate(0, ga);
    });
  }
  return out;
}

Tensor concat(const std::vector<Tensor>& tensors, int axis) {
  if (tensors.empty()) throw ValueError("concat: needs at least one tensor, got an empty list");
  for (std::size_t i = 0; i < tensors.size(); ++i) check_defined(tensors[i], "concat", "tensors[" + std::to_string(i) + "]");
  const Tensor& t0 = tensors[0];
  if (t0.rank() < 1) throw ShapeError("concat: tensors must have at least one axis, got tensors[0] " + t0.describe());
  const int ax = t0.shape().normalize_axis(axis, "concat: axis");
  // Same dtype and rank; equal extents except along `axis`.
  std::vector<std::int64_t> dims = t0.shape().dims();
  dims[static_cast<std::size_t>(ax)] = 0;
  for (std::size_t i = 0; i < tensors.size(); ++i) {
    const Tensor& t = tensors[i];
    if (t.dtype() != t0.dtype())
      throw DTypeError("concat: tensors[" + std::to_string(i) + "] " + t.describe() + " has a different dtype than tensors[0] " +
                       t0.describe());
    bool ok = t.rank() == t0.rank();
    for (int d = 0; ok && d < t.rank(); ++d) ok = d == ax || t.size(d) == t0.size(d);
    if (!ok)
      throw ShapeError("concat: tensors[" + std::to_string(i) + "] has shape " + t.shape().str() +
                       ", incompatible with tensors[0] " + t0.shape().str() + " (all extents must match except axis " +
                       std::to_string(ax) + ")");
    dims[static_cast<std::size_t>(ax)] = add_extents(dims[static_cast<std::size_t>(ax)], t.size(ax), "concat: the extents along axis " + std::to_string(ax));
  }
  const std::int64_t outer = prod(t0.shape(), 0, ax);
  std::vector<std::int64_t> chunk;
  for (const Tensor& t : tensors) chunk.push_back(outer == 0 ? 0 : t.numel() / outer);
  return join("concat", tensors, chunk, outer, Shape(dims));
}

Tensor stack(const std::vector<Tensor>& tensors, int axis) {
  if (tensors.empty()) throw ValueError("stack: needs at least one tensor, got an empty list");
  for (std::size_t i = 0; i < tensors.size(); ++i) check_defined(tensors[i], "stack", "tensors[" + std::to_string(i) + "]");
  const Tensor& t0 = tensors[0];
  const int rank = t0.rank();
  if (rank + 1 > Shape::kMaxRank)
    throw ShapeError("stack: tensors of shape " + t0.shape().str() + " would give a rank-" + std::to_string(rank + 1) +
                     " result (at most 4 supported)");
  if (axis < -(rank + 1) || axis > rank)
    throw IndexError("stack: axis " + std::to_string(axis) + " is out of range for a new axis of a rank-" +
                     std::to_string(rank + 1) + " result");
  const int ax = axis < 0 ? axis + rank + 1 : axis;
  // Equal shapes and dtypes.
  for (std::size_t i = 0; i < tensors.size(); ++i) {
    const Tensor& t = tensors[i];
    if (t.dtype() != t0.dtype())
      throw DTypeError("stack: tensors[" + std::to_string(i) + "] " + t.describe() + " has a different dtype than tensors[0] " +
                       t0.describe());
    if (t.shape() != t0.shape())
      throw ShapeError("stack: tensors[" + std::to_string(i) + "] has shape " + t.shape().str() +
                       ", expected the shape of tensors[0] " + t0.shape().str());
  }
  std::vector<std::int64_t> dims = t0.shape().dims();
  dims.insert(dims.begin() + ax, static_cast<std::int64_t>(tensors.size()));
  // Stacking is concatenation of [outer, 1, inner] views along the new axis.
  const std::int64_t outer = prod(t0.shape(), 0, ax);
  const std::vector<std::int64_t> chunk(tensors.size(), outer == 0 ? 0 : t0.numel() / outer);
  return join("stack", tensors, chunk, outer, Shape(dims));
}

Tensor gather(const Tensor& a, const Tensor& index) {
  check_defined(a, "gather", "a");
  if (a.rank() < 1) throw ShapeError("gather: argument 'a' must have at least one axis, got " + a.describe());
  check_index(index, a.size(0), "gather", "a has shape " + a.shape().str());
  // Result shape: index.shape + a.shape[1:].
  std::vector<std::int64_t> dims = index.shape().dims();
  for (int d = 1; d < a.rank(); ++d) dims.push_back(a.size(d));
  if (dims.size() > static_cast<std::size_t>(Shape::kMaxRank))
    throw ShapeError("gather: index " + index.shape().str() + " on a " + a.shape().str() + " gives a rank-" +
                     std::to_string(dims.size()) + " result (at most 4 supported)");
  const std::int64_t inner = prod(a.shape(), 1, a.rank()), rows = a.size(0);
  Tensor out = gather_raw(a, index, inner, Shape(dims));
  if (is_floating(a.dtype()) && should_record({a})) {
    // index: no gradient, checked for in-place writes (autodiff/tape.h).
    record("gather", {a, index}, {&out}, [index, inner, rows](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/da = scatter_add of g's rows into the picked rows (fixed order).
      ctx.accumulate(0, scatter_raw(g, index, rows, inner, ctx.input_shape(0)));
    });
  }
  return out;
}

Tensor scatter_add(const Tensor& src, const Tensor& index, std::int64_t rows) {
  check_defined(src, "scatter_add", "src");
  check_defined(index, "scatter_add", "index");
  if (rows < 0) throw ValueError("scatter_add: rows must be >= 0, got " + std::to_string(rows));
  // index.shape must be a prefix of src.shape.
  bool prefix = index.rank() <= src.rank();
  for (int d = 0; prefix && d < index.rank(); ++d) prefix = index.size(d) == src.size(d);
  if (!prefix)
    throw ShapeError("scatter_add: index shape " + index.shape().str() + " must be a prefix of src shape " +
                     src.shape().str());
  std::vector<std::int64_t> dims{rows};
  for (int d = index.rank(); d < src.rank(); ++d) dims.push_back(src.size(d));
  if (dims.size() > static_cast<std::size_t>(Shape::kMaxRank))
    throw ShapeError("scatter_add: result would have rank " + std::to_string(dims.size()) + " (at most 4 supported)");
  check_index(index, rows, "scatter_add", "rows = " + std::to_string(rows));
  const std::int64_t inner = prod(src.shape(), index.rank(), src.rank());
  Tensor out = scatter_raw(src, index, rows, inner, Shape(dims));
  if (is_floating(src.dtype()) && should_record({src})) {
    // index: no gradient, checked for in-place writes (autodiff/tape.h).
    record("scatter_add", {src, index}, {&out}, [index, inner](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/dsrc = gather(g, index).
      ctx.accumulate(0, gather_raw(g, index, inner, ctx.input_shape(0)));
    });
  }
  return out;
}

}  // namespace gr
