// The fused row interpreter's evaluator (ops/tensor/fused_rows.h): a compiled
// program (ops/tensor/fused_rows_program.h) run on chunks of kLanes lanes, forward
// and adjoint, over the elementwise op table's entries and the shared kernels.
#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>

#include "ops/tensor/broadcast.h"
#include "ops/tensor/elementwise_table.h"
#include "ops/tensor/fused_rows_program.h"

// Before a loop over lanes whose arrays never overlap (the arena gives each
// value its own): tells the vectorizer so, instead of leaving it to compare
// addresses at run time, which it gives up on for more than a few arrays.
#if defined(__clang__)
#define GR_INDEPENDENT_LANES _Pragma("clang loop vectorize(assume_safety)")
#elif defined(__GNUC__)
#define GR_INDEPENDENT_LANES _Pragma("GCC ivdep")
#else
#define GR_INDEPENDENT_LANES
#endif

namespace gr::detail {
namespace {

// Component j of an operand within a chunk: a lane array, or one value for all lanes.
template <class T>
struct Read {
  const T* p;
  T v;
};
template <class T>
struct ArrayRead {
  const T* p;
  T operator()(std::int64_t i) const { return p[i]; }
};
template <class T>
struct ConstRead {
  T v;
  T operator()(std::int64_t) const { return v; }
};

// f(x, z) with x and z as readers of their kind, so each combination is its own plain loop.
template <class T, class F>
[[gnu::always_inline]] inline void with_reads(const Read<T>& a, const Read<T>& b, F f) {
  auto with_b = [&](auto x) {
    if (b.p) f(x, ArrayRead<T>{b.p});
    else f(x, ConstRead<T>{b.v});
  };
  if (a.p) with_b(ArrayRead<T>{a.p});
  else with_b(ConstRead<T>{a.v});
}

// Rows [0, n) of a [rows, width] array to `width` lane arrays (dst + j kLanes),
// and back; rows of 2, 3 and 4 as loops of constant stride, which vectorize
// (a strided loop per component stored 4-float rows one float at a time:
// the loss's rgba gradient, issue 31).
template <int W, class T>
void deinterleave_fixed(const T* src, T* dst, std::int64_t n) {
  for (std::int64_t l = 0; l < n; ++l)
    for (int j = 0; j < W; ++j) dst[j * kLanes + l] = src[W * l + j];
}
template <int W, class T>
void interleave_fixed(const T* src, T* dst, std::int64_t n) {
  for (std::int64_t l = 0; l < n; ++l)
    for (int j = 0; j < W; ++j) dst[W * l + j] = src[j * kLanes + l];
}
template <class T>
void deinterleave(const T* src, std::int64_t width, T* dst, std::int64_t n) {
  switch (width) {
    case 1: std::copy(src, src + n, dst); return;
    case 2: deinterleave_fixed<2>(src, dst, n); return;
    case 3: deinterleave_fixed<3>(src, dst, n); return;
    case 4: deinterleave_fixed<4>(src, dst, n); return;
    default:
      for (std::int64_t j = 0; j < width; ++j)
        for (std::int64_t l = 0; l < n; ++l) dst[j * kLanes + l] = src[l * width + j];
  }
}
template <class T>
void interleave(const T* src, std::int64_t width, T* dst, std::int64_t n) {
  switch (width) {
    case 1: std::copy(src, src + n, dst); return;
    case 2: interleave_fixed<2>(src, dst, n); return;
    case 3: interleave_fixed<3>(src, dst, n); return;
    case 4: interleave_fixed<4>(src, dst, n); return;
    default:
      for (std::int64_t j = 0; j < width; ++j)
        for (std::int64_t l = 0; l < n; ++l) dst[l * width + j] = src[j * kLanes + l];
  }
}

}  // namespace

// One call's evaluation state: a lane array for every value's component, its
// gradient's and normalize's lengths, and double lane arrays for the shared
// inputs' partial gradient sums. Chunks of up to kLanes rows run through it.
template <class T>
class FusedEvaluator {
 public:
  using Value = FusedRows::Value;
  using Operand = FusedRows::Operand;
  using Instr = FusedRows::Instr;

  explicit FusedEvaluator(const FusedRows& p) : p_(p), scratch_(scratch()) {
    // The thread's buffers, kept between calls: fresh ones of this size would
    // come from mmap, a page fault per 4 KiB on every call.
    scratch_.arena.resize(std::size_t(p.arena_arrays_ * kLanes));
    scratch_.partial.assign(std::size_t(p.partial_arrays_ * kLanes), 0.0);
  }

  // Loads rows [c0, c0 + n) of the inputs the result depends on and runs the forward.
  void forward(const std::vector<Tensor>& rows, std::int64_t c0, std::int64_t n) {
    n_ = n;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const int v = p_.row_values_[i];
      if (v < 0 || !p_.values_[v].live) continue;
      const Value& val = p_.values_[v];
      deinterleave(rows[i].data<T>() + c0 * val.width, val.width, lanes(val.array), n);
    }
    for (const Instr& in : p_.instrs_)
      if (p_.values_[in.out].live) {
        run_forward(in);
        pump();
      }
  }

  // The next chunk's rows of the inputs and outputs, asked for a few cache
  // lines after each instruction (pump): the chunk's own loads and stores
  // then find them in cache instead of waiting on memory, and the requests
  // are spread out so they never fill the core's miss queue at once.
  void plan_prefetch(const std::vector<Tensor>& rows, const Tensor* out, const Tensor* g,
                     const std::vector<Tensor>* row_grads, std::int64_t c0, std::int64_t n) {
    streams_.clear();
    auto add = [&](const Tensor& t, std::int64_t width, bool write) {
      streams_.push_back({reinterpret_cast<const char*>(t.data<T>() + c0 * width), n * width * std::int64_t(sizeof(T)), write});
    };
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const int v = p_.row_values_[i];
      if (v < 0) continue;
      if (p_.values_[v].live) add(rows[i], p_.values_[v].width, false);
      if (row_grads && (*row_grads)[i].defined()) add((*row_grads)[i], p_.values_[v].width, true);
    }
    const std::int64_t result_width = p_.values_[p_.result_].width;
    if (out) add(*out, result_width, true);
    if (g) add(*g, result_width, false);
    stream_ = 0, offset_ = 0;
    std::int64_t lines = 0;
    for (const Stream& st : streams_) lines += (st.bytes + 63) / 64;
    const std::int64_t steps = std::max<std::int64_t>(1, std::int64_t(p_.instrs_.size()) * (row_grads ? 2 : 1));
    per_pump_ = (lines + steps - 1) / steps;
  }
  void pump() {
    for (std::int64_t k = 0; k < per_pump_ && stream_ < streams_.size(); ++k) {
      const Stream& st = streams_[stream_];
      if (st.write)
        __builtin_prefetch(st.p + offset_, 1);
      else
        __builtin_prefetch(st.p + offset_, 0);
      offset_ += 64;
      if (offset_ >= st.bytes) ++stream_, offset_ = 0;
    }
  }

  // Writes the lane arrays from `array` on (or zeros, for array < 0) to n_ rows of width `width`.
  void store(std::int64_t array, std::int64_t width, T* dst_rows) const {
    if (array < 0)
      std::fill(dst_rows, dst_rows + n_ * width, T(0));
    else
      interleave(lanes(array), width, dst_rows, n_);
  }
  void store_result(T* out_rows) const { store(p_.values_[p_.result_].array, p_.values_[p_.result_].width, out_rows); }

  // The backward of the chunk last run forward, from upstream rows `g_rows`
  // (or `seed` in every lane, when null); writes the row inputs' gradients
  // where row_grads[i] is defined.
  void backward(const T* g_rows, T seed, std::vector<Tensor>& row_grads, std::int64_t c0) {
    const Value& r = p_.values_[p_.result_];
    if (g_rows)
      deinterleave(g_rows, r.width, lanes(r.grad), n_);
    else
      std::fill(lanes(r.grad), lanes(r.grad) + r.width * kLanes, seed);
    for (auto i = p_.instrs_.rbegin(); i != p_.instrs_.rend(); ++i)
      if (i->backward) {
        run_backward(*i);
        pump();
      }
    for (std::size_t i = 0; i < row_grads.size(); ++i) {
      const int v = p_.row_values_[i];
      if (!row_grads[i].defined() || v < 0) continue;  // not a value: zeroed by evaluate()
      const Value& val = p_.values_[v];
      store(val.grad, val.width, row_grads[i].data<T>() + c0 * val.width);
    }
  }

  // A buffer for the result's values of `lanes` lanes of `width` (the thread's, reused).
  T* values(std::int64_t lanes, std::int64_t width) {
    if (scratch_.values.size() < std::size_t(lanes * width)) scratch_.values.resize(std::size_t(lanes * width));
    return scratch_.values.data();
  }

  // Shared input j's gradient over every chunk run so far: each lane
  // position's double sum, added over positions in order.
  Tensor shared_grad(std::size_t j) const {
    const int v = p_.shared_values_[j];
    if (v < 0 || p_.values_[v].grad < 0) return Tensor();
    const Value& val = p_.values_[v];
    Tensor out = Tensor::empty(p_.shared_shapes_[j], p_.dtype_);
    for (int c = 0; c < val.width; ++c) {
      const double* s = scratch_.partial.data() + (val.grad + c) * kLanes;
      double total = 0;
      for (std::int64_t l = 0; l < kLanes; ++l) total += s[l];
      out.data<T>()[c] = T(total);
    }
    return out;
  }

 private:
  T* lanes(std::int64_t array) { return scratch_.arena.data() + array * kLanes; }
  const T* lanes(std::int64_t array) const { return scratch_.arena.data() + array * kLanes; }

  Read<T> read(const Operand& o, int j) {
    const Value& v = p_.values_[o.value];
    const int c = o.spread ? 0 : j;
    if (v.varying) return {lanes(v.array + c), T(0)};
    return {nullptr, T(p_.uniforms_[std::size_t(v.array + c)])};
  }

  void run_forward(const Instr& in) {
    const Value& o = p_.values_[in.out];
    const std::int64_t n = n_;
    auto binary = [&](auto f) {
      for (int j = 0; j < in.components; ++j) {
        T* out = lanes(o.array + j);
        with_reads(read(in.a, j), read(in.b, j), [&](auto x, auto z) {
          for (std::int64_t l = 0; l < n; ++l) out[l] = T(f(x(l), z(l)));
        });
      }
    };
    switch (in.op.kind) {  // the table's formulas (ops/tensor/elementwise_table.h); pow, dot and normalize as eagerly
      case OpKind::Unary:
        visit_entry(UnaryOps{}, in.op.index, [&](auto entry) {
          using Op = decltype(entry);
          for (int j = 0; j < in.components; ++j) {
            const T* x = read(in.a, j).p;
            T* out = lanes(o.array + j);
            for (std::int64_t l = 0; l < n; ++l) out[l] = Op::forward(x[l]);
          }
        });
        break;
      case OpKind::Binary:
        visit_entry(BinaryOps{}, in.op.index, [&](auto entry) {
          binary([](T x, T z) { return decltype(entry)::forward(x, z); });
        });
        break;
      case OpKind::Power:
        for (int j = 0; j < in.components; ++j) power_range(read(in.a, j).p, lanes(o.array + j), 0, n, in.param);
        break;
      case OpKind::Clamp: {
        const T lo = T(in.param), hi = T(in.param2);
        for (int j = 0; j < in.components; ++j) {
          const T* x = read(in.a, j).p;
          T* out = lanes(o.array + j);
          for (std::int64_t l = 0; l < n; ++l) out[l] = ClampOp::forward(x[l], lo, hi);
        }
        break;
      }
      case OpKind::Dot: {  // sum_j a_j b_j in double from 0, rounded once
        if (unrolled(in.components, [&](auto c) { dot_lanes<c()>(in, lanes(o.array)); })) break;
        double s[kLanes];
        std::fill(s, s + n, 0.0);
        for (int j = 0; j < in.components; ++j)
          with_reads(read(in.a, j), read(in.b, j), [&](auto x, auto z) {
            for (std::int64_t l = 0; l < n; ++l) s[l] += double(x(l)) * double(z(l));
          });
        T* out = lanes(o.array);
        for (std::int64_t l = 0; l < n; ++l) out[l] = T(s[l]);
        break;
      }
      case OpKind::Normalize: {  // v / d, d = max(|v|, eps) in double (detail::normalized)
        if (unrolled(in.components, [&](auto c) { normalize_lanes<c()>(in, o); })) break;
        double d[kLanes], inv[kLanes];
        std::fill(d, d + n, 0.0);
        for (int j = 0; j < in.components; ++j) {
          const T* x = read(in.a, j).p;
          for (std::int64_t l = 0; l < n; ++l) d[l] += double(x[l]) * double(x[l]);
        }
        T* len = lanes(o.aux);
        for (std::int64_t l = 0; l < n; ++l) {
          d[l] = std::max<double>(std::sqrt(d[l]), in.param);
          len[l] = T(d[l]);
        }
        if constexpr (std::is_same_v<T, float>)  // float32 multiplies by 1 / d; float64 divides
          for (std::int64_t l = 0; l < n; ++l) inv[l] = 1 / d[l];
        for (int j = 0; j < in.components; ++j) {
          const T* x = read(in.a, j).p;
          T* out = lanes(o.array + j);
          for (std::int64_t l = 0; l < n; ++l)
            out[l] = normalized<T>(double(x[l]), d[l], std::is_same_v<T, float> ? inv[l] : 0.0);
        }
        break;
      }
    }
  }

  // Where an operand's gradient terms go, component by component: its lanes
  // (assigned for the first contribution, else added), a column's double sum
  // over the components (rounded once at finish, as sum_into_operand does),
  // or a shared input's partial sums. negate: the terms' negation goes in
  // (sub's b), applied after a column's rounding as the eager -reduce(g) does.
  class Sink {
   public:
    Sink(FusedEvaluator& e, const Operand& o, bool first, bool negate)
        : e_(e), o_(o), first_(first), negate_(negate), on_(o.value >= 0 && e.p_.values_[o.value].grad >= 0) {}
    bool on() const { return on_; }
    // Component j's terms, term(l) for each lane l (in T), go in as they are
    // computed: one loop per component, no pass over a scratch array.
    template <class F>
    void apply(int j, F term) {
      if (!on_) return;
      const Value& v = e_.p_.values_[o_.value];
      const std::int64_t n = e_.n_;
      if (!v.varying) {
        double* s = e_.scratch_.partial.data() + (v.grad + (o_.spread ? 0 : j)) * kLanes;
        if (negate_) {
          GR_INDEPENDENT_LANES
          for (std::int64_t l = 0; l < n; ++l) s[l] -= double(term(l));
        } else {
          GR_INDEPENDENT_LANES
          for (std::int64_t l = 0; l < n; ++l) s[l] += double(term(l));
        }
      } else if (column()) {  // summed from 0 in double, as sum_into_operand does
        if (started_) {
          GR_INDEPENDENT_LANES
          for (std::int64_t l = 0; l < n; ++l) sum_[l] += double(term(l));
        } else {
          GR_INDEPENDENT_LANES
          for (std::int64_t l = 0; l < n; ++l) sum_[l] = 0.0 + double(term(l));
        }
        started_ = true;
      } else {
        into_lanes(e_.lanes(v.grad + j), term);
      }
    }
    // Where to compute component j's terms for put(): straight into the
    // gradient's lanes when they are its first contribution as they are, else `scratch`.
    T* target(int j, T* scratch) {
      if (on_ && first_ && !negate_ && e_.p_.values_[o_.value].varying && !column())
        return e_.lanes(e_.p_.values_[o_.value].grad + j);
      return scratch;
    }
    void put(int j, const T* t) {
      if (t != target(j, nullptr)) apply(j, ArrayRead<T>{t});
    }
    void finish() {
      if (!on_ || !column()) return;
      if (!started_) std::fill(sum_, sum_ + e_.n_, 0.0);
      into_lanes(e_.lanes(e_.p_.values_[o_.value].grad), [&](std::int64_t l) { return T(sum_[l]); });
    }

   private:
    bool column() const { return o_.spread && e_.p_.values_[o_.value].varying; }
    // The terms into a row value's gradient lanes: assigned by the first
    // contribution, else added; negated (after rounding) for sub's b.
    template <class F>
    void into_lanes(T* dst, F term) {
      const std::int64_t n = e_.n_;
      if (first_ && negate_) {
        GR_INDEPENDENT_LANES
        for (std::int64_t l = 0; l < n; ++l) dst[l] = -term(l);
      } else if (first_) {
        GR_INDEPENDENT_LANES
        for (std::int64_t l = 0; l < n; ++l) dst[l] = term(l);
      } else if (negate_) {
        GR_INDEPENDENT_LANES
        for (std::int64_t l = 0; l < n; ++l) dst[l] = dst[l] + -term(l);
      } else {
        GR_INDEPENDENT_LANES
        for (std::int64_t l = 0; l < n; ++l) dst[l] = dst[l] + term(l);
      }
    }
    FusedEvaluator& e_;
    Operand o_;
    bool first_, negate_, on_, started_ = false;
    double sum_[kLanes];
  };

  // The unrolled kernels below run one loop over the lanes with every
  // component in registers, for the component counts of 3-vectors and
  // 4-vectors; other counts take a loop per component. Same operations in the
  // same order either way, so the same bits.
  template <class F>
  static bool unrolled(int components, F f) {
    switch (components) {
      case 3: f(std::integral_constant<int, 3>()); return true;
      case 4: f(std::integral_constant<int, 4>()); return true;
      default: return false;
    }
  }

  // f(x, z): the two operands' C components as arrays of readers of their kind.
  template <int C, class F>
  void with_component_reads(const Operand& a, const Operand& b, F f) {
    auto readers = [&](const Operand& op, auto g) {
      const Value& v = p_.values_[op.value];
      if (v.varying) {
        std::array<ArrayRead<T>, C> r;
        for (int j = 0; j < C; ++j) r[j] = {lanes(v.array + j)};
        g(r);
      } else {
        std::array<ConstRead<T>, C> r;
        for (int j = 0; j < C; ++j) r[j] = {T(p_.uniforms_[std::size_t(v.array + j)])};
        g(r);
      }
    };
    readers(a, [&](const auto& x) { readers(b, [&](const auto& z) { f(x, z); }); });
  }

  template <int C>
  void dot_lanes(const Instr& in, T* out) {
    with_component_reads<C>(in.a, in.b, [&](const auto& x, const auto& z) {
      GR_INDEPENDENT_LANES
      for (std::int64_t l = 0; l < n_; ++l) {
        double s = 0;
        for (int j = 0; j < C; ++j) s += double(x[j](l)) * double(z[j](l));
        out[l] = T(s);
      }
    });
  }

  template <int C>
  void normalize_lanes(const Instr& in, const Value& o) {
    const T* x[C];
    T* out[C];
    for (int j = 0; j < C; ++j) x[j] = read(in.a, j).p, out[j] = lanes(o.array + j);
    T* len = lanes(o.aux);
    const double eps = in.param;
    GR_INDEPENDENT_LANES
    for (std::int64_t l = 0; l < n_; ++l) {
      double d = 0;
      for (int j = 0; j < C; ++j) d += double(x[j][l]) * double(x[j][l]);
      d = std::max<double>(std::sqrt(d), eps);
      len[l] = T(d);
      const double inv = std::is_same_v<T, float> ? 1 / d : 0.0;
      for (int j = 0; j < C; ++j) out[j][l] = normalized<T>(double(x[j][l]), d, inv);
    }
  }

  template <int C>
  void normalize_adjoint_lanes(const Instr& in, const Value& o, Sink& sa) {
    const T *nj[C], *gj[C];
    T t[C][kLanes], *ta[C];
    for (int j = 0; j < C; ++j) nj[j] = lanes(o.array + j), gj[j] = lanes(o.grad + j), ta[j] = sa.target(j, t[j]);
    const T* len = lanes(o.aux);
    const T eps = T(in.param);
    int below = 0;  // any lane at or below eps (rare)
    GR_INDEPENDENT_LANES
    for (std::int64_t l = 0; l < n_; ++l) {
      double ng = 0;
      for (int j = 0; j < C; ++j) ng += double(nj[j][l]) * double(gj[j][l]);
      const double inv = 1 / double(len[l]);
      for (int j = 0; j < C; ++j) ta[j][l] = T((double(gj[j][l]) - double(nj[j][l]) * ng) * inv);
      below |= !(len[l] > eps);
    }
    for (int j = 0; j < C; ++j) {
      if (below)
        for (std::int64_t l = 0; l < n_; ++l)
          if (!(len[l] > eps)) ta[j][l] = gj[j][l] == T(0) ? gj[j][l] : T(double(gj[j][l]) / in.param);
      sa.put(j, ta[j]);
    }
  }

  void run_backward(const Instr& in) {
    const Value& o = p_.values_[in.out];
    const std::int64_t n = n_;
    Sink sa(*this, in.a, in.a_first, false), sb(*this, in.b, in.b_first, in.negate_b);
    T t[kLanes];
    switch (in.op.kind) {  // the table's adjoints (ops/tensor/elementwise_table.h); pow, dot and normalize as eagerly
      case OpKind::Unary:
        visit_entry(UnaryOps{}, in.op.index, [&](auto entry) {
          using Op = decltype(entry);
          for (int j = 0; j < in.components; ++j) {
            const T *g = lanes(o.grad + j), *x = read(in.a, j).p, *y = lanes(o.array + j);
            sa.apply(j, [&](std::int64_t l) { return Op::adjoint(g[l], x[l], y[l]); });
          }
        });
        break;
      case OpKind::Binary:
        visit_entry(BinaryOps{}, in.op.index, [&](auto entry) {
          using Op = decltype(entry);
          if constexpr (Op::linear) {  // g to each side (b's negated by its sink)
            for (int j = 0; j < in.components; ++j) sa.put(j, lanes(o.grad + j)), sb.put(j, lanes(o.grad + j));
          } else {  // each side's terms per component (y: the op's result)
            for (int j = 0; j < in.components; ++j) {
              const T* g = lanes(o.grad + j);
              const T* y = lanes(o.array + j);
              with_reads(read(in.a, j), read(in.b, j), [&](auto x, auto z) {
                auto y_at = [&](std::int64_t l) { return Op::uses_result ? y[l] : T(0); };
                sa.apply(j, [&](std::int64_t l) { return Op::adjoint_a(g[l], x(l), z(l), y_at(l)); });
                sb.apply(j, [&](std::int64_t l) { return Op::adjoint_b(g[l], x(l), z(l), y_at(l)); });
              });
            }
          }
        });
        break;
      case OpKind::Power:
        for (int j = 0; j < in.components; ++j) {
          T* ta = sa.target(j, t);
          power_adjoint_range(lanes(o.grad + j), read(in.a, j).p, ta, 0, n, in.param);
          sa.put(j, ta);
        }
        break;
      case OpKind::Clamp: {
        const T lo = T(in.param), hi = T(in.param2);
        for (int j = 0; j < in.components; ++j) {
          const T *g = lanes(o.grad + j), *x = read(in.a, j).p;
          sa.apply(j, [&](std::int64_t l) { return ClampOp::adjoint(g[l], x[l], lo, hi); });
        }
        break;
      }
      case OpKind::Dot: {  // dL/da_j = g b_j, dL/db_j = g a_j
        const T* g = lanes(o.grad);
        for (int j = 0; j < in.components; ++j)
          with_reads(read(in.a, j), read(in.b, j), [&](auto x, auto z) {
            sa.apply(j, [&](std::int64_t l) { return g[l] * z(l); });
            sb.apply(j, [&](std::int64_t l) { return g[l] * x(l); });
          });
        break;
      }
      case OpKind::Normalize: {  // (g - n (n.g)) / d; below eps g / eps (g itself for g = +-0)
        if (unrolled(in.components, [&](auto c) { normalize_adjoint_lanes<c()>(in, o, sa); })) break;
        const T* len = lanes(o.aux);
        double ng[kLanes], inv[kLanes];
        std::fill(ng, ng + n, 0.0);
        for (int j = 0; j < in.components; ++j) {
          const T *nj = lanes(o.array + j), *gj = lanes(o.grad + j);
          for (std::int64_t l = 0; l < n; ++l) ng[l] += double(nj[l]) * double(gj[l]);
        }
        for (std::int64_t l = 0; l < n; ++l) inv[l] = 1 / double(len[l]);
        const T eps = T(in.param);
        int below = 0;  // any lane at or below eps (rare: checked once, vectorized)
        for (std::int64_t l = 0; l < n; ++l) below |= !(len[l] > eps);
        for (int j = 0; j < in.components; ++j) {
          const T *nj = lanes(o.array + j), *gj = lanes(o.grad + j);
          T* ta = sa.target(j, t);
          for (std::int64_t l = 0; l < n; ++l) ta[l] = T((double(gj[l]) - double(nj[l]) * ng[l]) * inv[l]);
          if (below)
            for (std::int64_t l = 0; l < n; ++l)
              if (!(len[l] > eps)) ta[l] = gj[l] == T(0) ? gj[l] : T(double(gj[l]) / in.param);
          sa.put(j, ta);
        }
        break;
      }
    }
    sa.finish();
    sb.finish();
  }

  const FusedRows& p_;
  struct Stream {
    const char* p;
    std::int64_t bytes;
    bool write;
  };
  std::vector<Stream> streams_;
  std::size_t stream_ = 0;
  std::int64_t offset_ = 0, per_pump_ = 0;

  struct Scratch {
    std::vector<T> arena;  // every lane array is written before it is read
    std::vector<double> partial;
    std::vector<T> values;  // the result's rows of a call, for their sums
  };
  // One per thread and type; an evaluator never runs inside another on one thread.
  static Scratch& scratch() {
    thread_local Scratch s;
    return s;
  }
  Scratch& scratch_;
  std::int64_t n_ = 0;
};

namespace {

// sums[r] = the values [r kSumBlock, (r + 1) kSumBlock) of v added in order
// from 0 in double, as reduce's full sum adds each run (ops/tensor/broadcast.cpp);
// the runs are independent, so they advance together.
// kRuns full runs at once, their sums in registers.
template <int kRuns, class T>
void full_run_sums(const T* v, double* sums) {
  double acc[kRuns] = {};
  for (std::int64_t i = 0; i < kSumBlock; ++i)
    for (int r = 0; r < kRuns; ++r) acc[r] += double(v[r * kSumBlock + i]);
  std::copy(acc, acc + kRuns, sums);
}

template <class T>
void run_sums(const T* v, std::int64_t count, double* sums) {
  const std::int64_t full = count / kSumBlock;
  std::int64_t r = 0;
  for (; r + 4 <= full; r += 4) full_run_sums<4>(v + r * kSumBlock, sums + r);
  switch (full - r) {
    case 3: full_run_sums<3>(v + r * kSumBlock, sums + r); break;
    case 2: full_run_sums<2>(v + r * kSumBlock, sums + r); break;
    case 1: full_run_sums<1>(v + r * kSumBlock, sums + r); break;
    default: break;
  }
  if (count > full * kSumBlock) {
    double tail = 0;
    for (std::int64_t i = full * kSumBlock; i < count; ++i) tail += double(v[i]);
    sums[full] = tail;
  }
}

}  // namespace

// Rows [lo, hi) in chunks: the forward, writing the result's rows to `out`
// or its run sums to `sums` (when given), then, when `row_grads` is given, the
// backward from upstream rows `g` (or `seed` for every element, when g is
// null). Returns the shared inputs' gradients over these rows.
std::vector<Tensor> FusedRows::evaluate(const std::vector<Tensor>& rows, Tensor* out, double* sums, const Tensor* g,
                                        double seed, std::vector<Tensor>* row_grads, std::int64_t lo, std::int64_t hi) const {
  std::vector<Tensor> shared(shared_values_.size());
  dispatch_float(dtype_, "map_rows", [&](auto tag) {
    using T = decltype(tag);
    FusedEvaluator<T> e(*this);
    const bool backward = row_grads && values_[result_].grad >= 0;
    // Gradients no lane array holds: rows f does not use, or everything when
    // nothing the result depends on needs a gradient.
    if (row_grads)
      for (std::size_t i = 0; i < row_grads->size(); ++i) {
        Tensor& rg = (*row_grads)[i];
        if (!rg.defined() || (backward && row_values_[i] >= 0)) continue;
        const std::int64_t per_row = rg.numel() / std::max<std::int64_t>(1, rg.size(0));
        std::fill(rg.data<T>() + lo * per_row, rg.data<T>() + hi * per_row, T(0));
      }
    const std::int64_t width = values_[result_].width;
    const std::int64_t first = lo * lanes_per_row_, last = hi * lanes_per_row_;  // rows to lanes
    T* const values = sums ? e.values(last - first, width) : nullptr;  // the result's values, for their sums
    for (std::int64_t c0 = first; c0 < last; c0 += kLanes) {
      const std::int64_t n = std::min(kLanes, last - c0);
      if (c0 + kLanes < last)
        e.plan_prefetch(rows, out, g, backward ? row_grads : nullptr, c0 + kLanes, std::min(kLanes, last - c0 - kLanes));
      if (out || sums || backward) e.forward(rows, c0, n);
      if (out) e.store_result(out->data<T>() + c0 * width);
      if (sums) e.store_result(values + (c0 - first) * width);
      if (backward) e.backward(g ? g->data<T>() + c0 * width : nullptr, T(seed), *row_grads, c0);
    }
    if (backward)
      for (std::size_t j = 0; j < shared.size(); ++j) shared[j] = e.shared_grad(j);
    if (sums) run_sums(values, (last - first) * width, sums);
  });
  return shared;
}

void FusedRows::forward(const std::vector<Tensor>& rows, Tensor& out, std::int64_t lo, std::int64_t hi) const {
  evaluate(rows, &out, nullptr, nullptr, 0, nullptr, lo, hi);
}

std::vector<Tensor> FusedRows::backward(const std::vector<Tensor>& rows, const Tensor& g, std::vector<Tensor>& row_grads,
                                        std::int64_t lo, std::int64_t hi) const {
  return evaluate(rows, nullptr, nullptr, &g, 0, &row_grads, lo, hi);
}

std::vector<Tensor> FusedRows::backward_uniform(const std::vector<Tensor>& rows, double seed, std::vector<Tensor>& row_grads,
                                                std::int64_t lo, std::int64_t hi, double* sums) const {
  return evaluate(rows, nullptr, sums, nullptr, seed, &row_grads, lo, hi);
}

}  // namespace gr::detail
