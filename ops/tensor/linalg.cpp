// Matrix products and transposes: matmul with batch broadcasting, transpose,
// to_homogeneous, and transform_points (a composite of the others), forward
// kernels and adjoints side by side.
//
// Every product is split into tasks fixed by the shapes alone (a batch and a
// block of output rows, or a block of the reduction axis whose partial sums are
// added in block order), so results are bit-identical for any thread count.
// Small inner dimensions (the N x 4 . 4 x 4 of vertex transforms) use unrolled
// loops; large ones use Eigen on fixed row blocks.
#include "ops/tensor/linalg.h"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

// Eigen is private to the library (docs/decisions.md): under its own namespace
// here, so the instantiations this file makes (compiled for the build machine,
// GRADRASTER_NATIVE) are not the weak Eigen::... symbols of a consumer's own
// Eigen code, and the linker cannot swap one for the other. No header of ours
// includes Eigen.
#define Eigen gr_private_eigen
#include <Eigen/Core>

#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/tensor/promote.h"

namespace gr {
namespace {

using Offsets = std::vector<std::int64_t>;

// Inner dimensions at or above which a product goes to Eigen.
constexpr std::int64_t kEigenMin = 16;
// Rows per task when Eigen multiplies a row block (fixed, so results are too).
constexpr std::int64_t kEigenRows = 64;
// Reduction rows per block of a^T g when the reduction axis is split.
constexpr std::int64_t kReduceBlock = 4096;

// C[r, :] = sum_p A[r, p] B[p, :] for rows [lo, hi), with compile-time k and m.
template <class T, int K, int M>
void mm_rows_fixed(const T* A, const T* B, T* C, std::int64_t lo, std::int64_t hi) {
  T b[K * M];
  for (int i = 0; i < K * M; ++i) b[i] = B[i];
  for (std::int64_t r = lo; r < hi; ++r) {
    const T* a = A + r * K;
    T* c = C + r * M;
    T acc[M];
    for (int j = 0; j < M; ++j) acc[j] = a[0] * b[j];
    for (int p = 1; p < K; ++p)
      for (int j = 0; j < M; ++j) acc[j] += a[p] * b[p * M + j];
    for (int j = 0; j < M; ++j) c[j] = acc[j];
  }
}

// Rows [lo, hi) of C = A B (A n x k, B k x m, row-major). Each output element
// is summed over p in ascending order, whatever the range.
template <class T>
void mm_rows(const T* A, const T* B, T* C, std::int64_t k, std::int64_t m, std::int64_t lo, std::int64_t hi) {
  // Specialized small shapes (vertex transforms and their adjoints).
  if (k == 4 && m == 4) return mm_rows_fixed<T, 4, 4>(A, B, C, lo, hi);
  if (k == 3 && m == 3) return mm_rows_fixed<T, 3, 3>(A, B, C, lo, hi);
  if (k == 4 && m == 3) return mm_rows_fixed<T, 4, 3>(A, B, C, lo, hi);
  if (k == 3 && m == 4) return mm_rows_fixed<T, 3, 4>(A, B, C, lo, hi);
  // General: c[r, :] = sum_p a[r, p] b[p, :], contiguous over the output row.
  for (std::int64_t r = lo; r < hi; ++r) {
    T* c = C + r * m;
    for (std::int64_t j = 0; j < m; ++j) c[j] = T(0);
    for (std::int64_t p = 0; p < k; ++p) {
      const T a = A[r * k + p];
      const T* b = B + p * m;
      for (std::int64_t j = 0; j < m; ++j) c[j] += a * b[j];
    }
  }
}

// C_t = A_t B_t for every batch t (A at a_off[t], B at b_off[t], C contiguous
// n x m matrices). Tasks are (batch, row block) pairs fixed by the shapes.
template <class T>
void mm_batched(const T* A, const Offsets& a_off, const T* B, const Offsets& b_off, T* C, std::int64_t n,
                std::int64_t k, std::int64_t m) {
  const std::int64_t batches = static_cast<std::int64_t>(a_off.size());
  if (n == 0 || m == 0 || batches == 0) return;
  const bool eigen = k >= kEigenMin && m >= kEigenMin && n >= kEigenMin;
  const std::int64_t block = eigen ? kEigenRows : std::max<std::int64_t>(1, 4096 / std::max<std::int64_t>(1, k * m));
  const std::int64_t blocks = (n + block - 1) / block;
  const std::int64_t work = block * std::max<std::int64_t>(1, k) * m;  // multiply-adds per task
  const std::int64_t grain = std::max<std::int64_t>(1, 32768 / work);
  parallel_for(0, batches * blocks, grain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t task = lo; task < hi; ++task) {
      const std::int64_t t = task / blocks, r0 = (task % blocks) * block, r1 = std::min(n, r0 + block);
      const T* a = A + a_off[t];
      const T* b = B + b_off[t];
      T* c = C + t * n * m;
      if (eigen) {
        // One fixed row block through Eigen's blocked product.
        using Mat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
        Eigen::Map<const Mat> ab(a + r0 * k, r1 - r0, k);
        Eigen::Map<const Mat> bm(b, k, m);
        Eigen::Map<Mat> cb(c + r0 * m, r1 - r0, m);
        cb.noalias() = ab * bm;
      } else {
        mm_rows(a, b, c, k, m, r0, r1);
      }
    }
  });
}

// C = A^T G (A n x k, G n x m, C k x m) for a long reduction axis n and a small
// C: blocks of n rows give partial sums (in double) that are added in block order.
template <class T>
void mm_tn_split(const T* A, const T* G, T* C, std::int64_t n, std::int64_t k, std::int64_t m) {
  const std::int64_t blocks = (n + kReduceBlock - 1) / kReduceBlock;
  std::vector<double> partial(static_cast<std::size_t>(blocks * k * m), 0.0);
  parallel_for(0, blocks, 1, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t blk = lo; blk < hi; ++blk) {
      double* acc = partial.data() + blk * k * m;
      const std::int64_t p1 = std::min(n, (blk + 1) * kReduceBlock);
      // acc[i, :] += a[p, i] g[p, :] over the block's rows.
      for (std::int64_t p = blk * kReduceBlock; p < p1; ++p)
        for (std::int64_t i = 0; i < k; ++i) {
          const double a = A[p * k + i];
          const T* g = G + p * m;
          for (std::int64_t j = 0; j < m; ++j) acc[i * m + j] += a * double(g[j]);
        }
    }
  });
  // Blocks summed in order.
  for (std::int64_t e = 0; e < k * m; ++e) {
    double s = 0;
    for (std::int64_t blk = 0; blk < blocks; ++blk) s += partial[static_cast<std::size_t>(blk * k * m + e)];
    C[e] = T(s);
  }
}

// Swaps the last two axes of `t` (rank >= 2) into a new tensor.
Tensor transpose_raw(const Tensor& t) {
  std::vector<std::int64_t> d = t.shape().dims();
  const std::int64_t r = d[d.size() - 2], c = d[d.size() - 1];
  std::swap(d[d.size() - 2], d[d.size() - 1]);
  Tensor out = Tensor::empty(Shape(d), t.dtype());
  auto run = [&](auto tag) {
    using T = decltype(tag);
    const T* in = t.data<T>();
    T* o = out.data<T>();
    // out[b, j, i] = in[b, i, j]; contiguous writes, one output row per step.
    const std::int64_t out_rows = t.numel() / std::max<std::int64_t>(1, r);
    parallel_for(0, r == 0 ? 0 : out_rows, std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, r)),
                 [&](std::int64_t lo, std::int64_t hi) {
                   for (std::int64_t row = lo; row < hi; ++row) {
                     const std::int64_t b = row / c, j = row % c;
                     const T* src = in + b * r * c + j;
                     T* dst = o + row * r;
                     for (std::int64_t i = 0; i < r; ++i) dst[i] = src[i * c];
                   }
                 });
  };
  switch (t.dtype()) {
    case DType::Float32: run(float{}); break;
    case DType::Float64: run(double{}); break;
    case DType::Int32: run(std::int32_t{}); break;
  }
  return out;
}

// Shape of a matmul: the broadcast batch, and where each batch's matrices start.
struct MatmulPlan {
  Shape out;                 // [batch..., n, m]
  std::int64_t n = 0, k = 0, m = 0;
  Offsets a_off, b_off;      // element offsets of each output batch's operands
  bool folded = false;       // b is a plain matrix: a's batch axes folded into its rows
};

// Element offsets of the matrices of `t` (batch axes `tb`) for every index of
// the broadcast batch `batch` (stride 0 along broadcast axes).
Offsets batch_offsets(const std::vector<std::int64_t>& tb, const std::vector<std::int64_t>& batch,
                      std::int64_t matrix_size) {
  const std::size_t rank = batch.size();
  std::vector<std::int64_t> stride(rank, 0);
  std::int64_t s = matrix_size;
  for (std::size_t i = rank; i-- > 0;) {
    const std::ptrdiff_t ti = static_cast<std::ptrdiff_t>(i) - static_cast<std::ptrdiff_t>(rank - tb.size());
    if (ti < 0) continue;
    if (tb[static_cast<std::size_t>(ti)] != 1) stride[i] = s;
    s *= tb[static_cast<std::size_t>(ti)];
  }
  std::int64_t count = 1;
  for (std::int64_t e : batch) count *= e;
  Offsets off(static_cast<std::size_t>(count));
  for (std::int64_t t = 0; t < count; ++t) {
    std::int64_t rest = t, o = 0;
    for (std::size_t i = rank; i-- > 0;) {
      o += (rest % batch[i]) * stride[i];
      rest /= batch[i];
    }
    off[static_cast<std::size_t>(t)] = o;
  }
  return off;
}

MatmulPlan plan_matmul(const Tensor& a, const Tensor& b) {
  detail::check_float(a, "matmul", "a");
  detail::check_float(b, "matmul", "b");
  if (a.dtype() != b.dtype())
    throw DTypeError("matmul: operands have different dtypes " + a.describe() + " and " + b.describe() +
                     " (use cast() to convert)");
  if (a.rank() < 2 || b.rank() < 2)
    throw ShapeError("matmul: operands must have rank >= 2 ([..., n, k] x [..., k, m]; reshape vectors), got a " +
                     a.shape().str() + " and b " + b.shape().str());
  MatmulPlan p;
  p.n = a.size(-2);
  p.k = a.size(-1);
  p.m = b.size(-1);
  if (b.size(-2) != p.k)
    throw ShapeError("matmul: inner dimensions differ: a " + a.shape().str() + " has k = " + std::to_string(p.k) +
                     " but b " + b.shape().str() + " has " + std::to_string(b.size(-2)) +
                     " rows (expected [..., n, k] x [..., k, m])");
  std::vector<std::int64_t> ab = a.shape().dims(), bb = b.shape().dims();
  ab.resize(ab.size() - 2);
  bb.resize(bb.size() - 2);
  std::vector<std::int64_t> batch(std::max(ab.size(), bb.size()));
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const std::ptrdiff_t ia = std::ptrdiff_t(i) - std::ptrdiff_t(batch.size() - ab.size());
    const std::ptrdiff_t ib = std::ptrdiff_t(i) - std::ptrdiff_t(batch.size() - bb.size());
    const std::int64_t da = ia >= 0 ? ab[std::size_t(ia)] : 1, db = ib >= 0 ? bb[std::size_t(ib)] : 1;
    if (da != db && da != 1 && db != 1)
      throw ShapeError("matmul: batch axes of a " + a.shape().str() + " and b " + b.shape().str() +
                       " cannot be broadcast together");
    batch[i] = da == 1 ? db : da;
  }
  std::vector<std::int64_t> out = batch;
  out.push_back(p.n);
  out.push_back(p.m);
  if (out.size() > static_cast<std::size_t>(Shape::kMaxRank))
    throw ShapeError("matmul: result of a " + a.shape().str() + " x b " + b.shape().str() + " would have rank " +
                     std::to_string(out.size()) + " (at most 4 supported)");
  p.out = Shape(out);
  if (bb.empty()) {
    // b is one matrix: a's batches are just more rows.
    p.folded = true;
    p.n = a.numel() / std::max<std::int64_t>(1, p.k);
    if (p.k == 0) p.n = p.out.numel() / std::max<std::int64_t>(1, p.m);
    p.a_off = {0};
    p.b_off = {0};
  } else if (p.out.numel() > 0) {
    // 16 bytes per batch, counted before they are taken (an empty result has
    // no batches to offset, however large its batch axes).
    check_memory_request(static_cast<std::size_t>(p.out.numel() / (p.n * p.m)) * 2 * sizeof(std::int64_t),
                                 "matmul's batch offsets");
    p.a_off = batch_offsets(ab, batch, p.n * p.k);
    p.b_off = batch_offsets(bb, batch, p.k * p.m);
  }
  return p;
}

// Offsets 0, s, 2s, ... of `count` contiguous matrices of size s.
Offsets contiguous_offsets(std::size_t count, std::int64_t s) {
  Offsets o(count);
  for (std::size_t i = 0; i < count; ++i) o[i] = static_cast<std::int64_t>(i) * s;
  return o;
}

}  // namespace

Tensor transpose(const Tensor& a) {
  detail::check_defined(a, "transpose", "a");
  if (a.rank() < 2)
    throw ShapeError("transpose: argument 'a' must have rank >= 2 (swaps the last two axes), got " + a.describe());
  Tensor out = transpose_raw(a);
  if (is_floating(a.dtype()) && should_record({a})) {
    record("transpose", {a}, {&out}, [](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/da = transpose(g).
      ctx.accumulate(0, transpose_raw(g));
    });
  }
  return out;
}

Tensor matmul(const Tensor& a_in, const Tensor& b_in) {
  Tensor a = a_in, b = b_in;
  detail::promote_floats({&a, &b});
  const MatmulPlan p = plan_matmul(a, b);
  Tensor out = Tensor::empty(p.out, a.dtype());
  dispatch_float(a.dtype(), "matmul", [&](auto tag) {
    using T = decltype(tag);
    if (p.k == 0) {  // empty inner axis: all zeros
      std::fill(out.data<T>(), out.data<T>() + out.numel(), T(0));
      return;
    }
    // C_t = A_t B_t for each broadcast batch. a and b are read through the
    // const data<T>(): the non-const one counts as a write (autodiff/tape.h).
    mm_batched(std::as_const(a).data<T>(), p.a_off, std::as_const(b).data<T>(), p.b_off, out.data<T>(), p.n, p.k,
               p.m);
  });
  if (should_record({a, b})) {
    record("matmul", {a, b}, {&out}, [a, b, p](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      if (p.out.numel() == 0) {  // nothing flows through an empty product
        for (std::size_t i = 0; i < 2; ++i)
          if (ctx.needs_grad(i)) ctx.accumulate(i, Tensor::zeros((i == 0 ? a : b).shape(), g.dtype()));
        return;
      }
      const std::size_t batches = p.a_off.size();
      dispatch_float(g.dtype(), "matmul", [&](auto tag) {
        using T = decltype(tag);
        if (ctx.needs_grad(0)) {
          // dL/da = g b^T per batch ([n, m] x [m, k]), summed over a's broadcast axes.
          std::vector<std::int64_t> d = p.out.dims();
          d.back() = p.k;
          Tensor full = Tensor::zeros(Shape(d), g.dtype());
          if (p.k > 0) {
            const Tensor bt = transpose_raw(b);
            mm_batched(g.data<T>(), contiguous_offsets(batches, p.n * p.m), bt.data<T>(), p.b_off, full.data<T>(),
                       p.n, p.m, p.k);
          }
          ctx.accumulate(0, detail::reduce_raw(full, a.shape()));
        }
        if (ctx.needs_grad(1)) {
          // dL/db = a^T g per batch ([k, n] x [n, m]), summed over b's broadcast axes.
          std::vector<std::int64_t> d = p.out.dims();
          d[d.size() - 2] = p.k;
          if (p.folded) d = {p.k, p.m};
          Tensor full = Tensor::zeros(Shape(d), g.dtype());
          if (p.k > 0 && p.m > 0) {
            if (batches * p.k < 64 && p.n >= 2 * kReduceBlock) {
              // Few small outputs over a long reduction: split the reduction axis.
              for (std::size_t t = 0; t < batches; ++t)
                mm_tn_split(a.data<T>() + p.a_off[t], g.data<T>() + std::int64_t(t) * p.n * p.m,
                            full.data<T>() + std::int64_t(t) * p.k * p.m, p.n, p.k, p.m);
            } else {
              // Otherwise materialize a^T and parallelize over output rows.
              Tensor a_mat = a.detach();
              if (p.folded) a_mat.impl()->shape = Shape{p.n, p.k};  // a seen as one [n, k] matrix
              const Tensor at = transpose_raw(a_mat);
              mm_batched(at.data<T>(), p.a_off, g.data<T>(),
                         contiguous_offsets(batches, p.n * p.m), full.data<T>(), p.k, p.n, p.m);
            }
          }
          ctx.accumulate(1, detail::reduce_raw(full, b.shape()));
        }
      });
    });
  }
  return out;
}

Tensor to_homogeneous(const Tensor& points) {
  detail::check_float(points, "to_homogeneous", "points");
  if (points.rank() < 1 || points.size(-1) != 3)
    throw ShapeError("to_homogeneous: argument 'points' must have shape [..., 3], got " + points.describe());
  std::vector<std::int64_t> d = points.shape().dims();
  d.back() = 4;
  Tensor out = Tensor::empty(Shape(d), points.dtype());
  const std::int64_t rows = points.numel() / 3;
  dispatch_float(points.dtype(), "to_homogeneous", [&](auto tag) {
    using T = decltype(tag);
    const T* p = points.data<T>();
    T* o = out.data<T>();
    // (x, y, z) -> (x, y, z, 1).
    parallel_for(0, rows, kElementwiseGrain / 4, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t r = lo; r < hi; ++r) {
        o[4 * r] = p[3 * r];
        o[4 * r + 1] = p[3 * r + 1];
        o[4 * r + 2] = p[3 * r + 2];
        o[4 * r + 3] = T(1);
      }
    });
  });
  if (should_record({points})) {
    record("to_homogeneous", {points}, {&out}, [rows](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor gp = Tensor::empty(ctx.input_shape(0), g.dtype());
      dispatch_float(g.dtype(), "to_homogeneous", [&](auto tag) {
        using T = decltype(tag);
        const T* pg = g.data<T>();
        T* o = gp.data<T>();
        // dL/dp = g[..., :3] (w is a constant).
        parallel_for(0, rows, kElementwiseGrain / 4, [&](std::int64_t lo, std::int64_t hi) {
          for (std::int64_t r = lo; r < hi; ++r) {
            o[3 * r] = pg[4 * r];
            o[3 * r + 1] = pg[4 * r + 1];
            o[3 * r + 2] = pg[4 * r + 2];
          }
        });
      });
      ctx.accumulate(0, gp);
    });
  }
  return out;
}

Tensor transform_points(const Tensor& points_in, const Tensor& matrix_in) {
  Tensor points = points_in, matrix = matrix_in;
  detail::promote_floats({&points, &matrix});
  detail::check_float(points, "transform_points", "points");
  detail::check_float(matrix, "transform_points", "matrix");
  if (points.dtype() != matrix.dtype())
    throw DTypeError("transform_points: 'points' " + points.describe() + " and 'matrix' " + matrix.describe() +
                     " have different dtypes (use cast() to convert)");
  if (points.rank() < 2 || (points.size(-1) != 3 && points.size(-1) != 4))
    throw ShapeError("transform_points: argument 'points' must have shape [N, 3] or [N, 4], got " +
                     points.describe());
  if (matrix.rank() < 2 || matrix.size(-1) != 4 || matrix.size(-2) != 4)
    throw ShapeError("transform_points: argument 'matrix' must have shape [4, 4], got " + matrix.describe());
  // Composite: p' = M p for row vectors is P_h M^T.
  const Tensor ph = points.size(-1) == 3 ? to_homogeneous(points) : points;
  return matmul(ph, transpose(matrix));
}

}  // namespace gr
