// The elementwise op table: each elementwise op defined once, as an entry with
// its name, its forward formula and its adjoint formulas per element. Both
// evaluators run the entries: the eager ops (ops/tensor/elementwise.cpp, one line
// each) and the fused row interpreter behind map_rows (ops/tensor/fused_rows.cpp,
// docs/map_rows.md), so an op added here is an eager op and a replayed one at
// once, with the same bits (tests/ops/tensor/test_elementwise_table.cpp checks every
// entry's eager op against its replay, forward and adjoint, float32 and float64).
// To add an op: its entry below, listed in UnaryOps or BinaryOps, and its
// public function (declared in ops/tensor/elementwise.h, one line in elementwise.cpp).
//
// Entries are types with static members:
//   unary:  name; forward(x); adjoint(g, x, y)                     (y = forward(x))
//   binary: name; forward(x, z); and either
//           linear = false, uses_result, adjoint_a(g, x, z, y), adjoint_b(g, x, z, y)
//             (y: the result, passed as 0 unless uses_result), or
//           linear = true, negate_b: dL/da = g and dL/db = +-g, each summed over
//             the positions that read the operand, b's sum then negated (so a +0
//             sum gives -0 for sub, as -reduce(g) does).
// Broadcast operands' adjoint terms are summed back to the operand's shape by
// the evaluator. Formulas return T and are evaluated in T.
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>

#include "autodiff/base/tensor.h"
#include "ops/tensor/elementwise_formulas.h"

namespace gr::detail {

// ---------------------------------------------------------------- unary entries

struct NegOp {
  static constexpr const char* name = "neg";
  template <class T> static T forward(T x) { return -x; }
  template <class T> static T adjoint(T g, T, T) { return -g; }  // -g
};

struct ExpOp {
  static constexpr const char* name = "exp";
  template <class T> static T forward(T x) { return std::exp(x); }
  template <class T> static T adjoint(T g, T, T y) { return g * y; }  // g exp(x)
};

struct LogOp {
  static constexpr const char* name = "log";
  template <class T> static T forward(T x) { return std::log(x); }
  template <class T> static T adjoint(T g, T x, T) { return g / x; }  // g / x (+-inf at 0)
};

struct SqrtOp {
  static constexpr const char* name = "sqrt";
  template <class T> static T forward(T x) { return std::sqrt(x); }
  // g / (2 sqrt(x)), 0 at x == 0
  template <class T> static T adjoint(T g, T, T y) { return y == 0 ? T(0) : g / (2 * y); }
};

struct RsqrtOp {
  static constexpr const char* name = "rsqrt";
  template <class T> static T forward(T x) { return 1 / std::sqrt(x); }
  template <class T> static T adjoint(T g, T, T y) { return -g * y * y * y / 2; }  // -g rsqrt(x)^3 / 2
};

struct SinOp {
  static constexpr const char* name = "sin";
  template <class T> static T forward(T x) { return std::sin(x); }
  template <class T> static T adjoint(T g, T x, T) { return g * std::cos(x); }
};

struct CosOp {
  static constexpr const char* name = "cos";
  template <class T> static T forward(T x) { return std::cos(x); }
  template <class T> static T adjoint(T g, T x, T) { return -g * std::sin(x); }
};

struct AbsOp {
  static constexpr const char* name = "abs";
  template <class T> static T forward(T x) { return std::fabs(x); }
  template <class T> static T adjoint(T g, T x, T) { return x > 0 ? g : x < 0 ? -g : T(0); }  // g sign(x), sign(0) = 0
};

// clamp(x, lo, hi): a unary op with two parameters, so not an entry of
// UnaryOps (whose formulas take x alone) but an op of its own kind (OpKind::Clamp),
// with its formulas here for both evaluators. g inside [lo, hi] (bounds included), 0 outside.
struct ClampOp {
  static constexpr const char* name = "clamp";
  template <class T> static T forward(T x, T lo, T hi) { return x < lo ? lo : x > hi ? hi : x; }
  template <class T> static T adjoint(T g, T x, T lo, T hi) { return (x >= lo && x <= hi) ? g : T(0); }
};

// ---------------------------------------------------------------- binary entries

struct AddOp {
  static constexpr const char* name = "add";
  static constexpr bool linear = true, negate_b = false;
  template <class T> static T forward(T x, T z) { return x + z; }
};

struct SubOp {
  static constexpr const char* name = "sub";
  static constexpr bool linear = true, negate_b = true;
  template <class T> static T forward(T x, T z) { return x - z; }
};

struct MulOp {
  static constexpr const char* name = "mul";
  static constexpr bool linear = false, uses_result = false;
  template <class T> static T forward(T x, T z) { return x * z; }
  template <class T> static T adjoint_a(T g, T, T z, T) { return g * z; }
  template <class T> static T adjoint_b(T g, T x, T, T) { return g * x; }
};

struct DivOp {
  static constexpr const char* name = "div";
  static constexpr bool linear = false, uses_result = true;
  template <class T> static T forward(T x, T z) { return x / z; }
  template <class T> static T adjoint_a(T g, T, T z, T) { return g / z; }
  // -(g y) / z = -(g x/z) / z, in that order so that a tiny z does not underflow z^2
  template <class T> static T adjoint_b(T g, T, T z, T y) { return -(g * y) / z; }
};

struct PowOp {
  static constexpr const char* name = "pow";
  static constexpr bool linear = false, uses_result = true;
  template <class T> static T forward(T x, T z) { return std::pow(x, z); }
  // g z x^(z-1), 0 where x == 0 and z < 1 (the derivative diverges)
  template <class T> static T adjoint_a(T g, T x, T z, T) {
    if (x == T(0) && z < T(1)) return T(0);
    return T(g * z * std::pow(x, z - T(1)));
  }
  // g x^z ln(x) for x > 0, 0 for x <= 0
  template <class T> static T adjoint_b(T g, T x, T, T y) { return x > T(0) ? T(g * y * std::log(x)) : T(0); }
};

// At a tie the gradient is split evenly (g/2 to each; selected_gradient).
struct MinimumOp {
  static constexpr const char* name = "minimum";
  static constexpr bool linear = false, uses_result = false;
  template <class T> static T forward(T x, T z) { return z < x ? z : x; }
  template <class T> static T adjoint_a(T g, T x, T z, T) { return selected_gradient(g, x < z, x == z); }
  template <class T> static T adjoint_b(T g, T x, T z, T) { return selected_gradient(g, z < x, x == z); }
};

struct MaximumOp {
  static constexpr const char* name = "maximum";
  static constexpr bool linear = false, uses_result = false;
  template <class T> static T forward(T x, T z) { return z > x ? z : x; }
  template <class T> static T adjoint_a(T g, T x, T z, T) { return selected_gradient(g, x > z, x == z); }
  template <class T> static T adjoint_b(T g, T x, T z, T) { return selected_gradient(g, z > x, x == z); }
};

// ---------------------------------------------------------------- the table

template <class... Ops>
struct OpList {
  static constexpr int size = int(sizeof...(Ops));
};

using UnaryOps = OpList<NegOp, ExpOp, LogOp, SqrtOp, RsqrtOp, SinOp, CosOp, AbsOp>;
using BinaryOps = OpList<AddOp, SubOp, MulOp, DivOp, PowOp, MinimumOp, MaximumOp>;

// What a traced step is: an entry of UnaryOps or BinaryOps (by its index), or
// one of the ops with kernels or parameters of their own: pow with a constant
// exponent (power_range, power_adjoint_range), clamp (ClampOp), dot and
// normalize (ops/tensor/vector.h).
enum class OpKind { Unary, Binary, Power, Clamp, Dot, Normalize };
struct OpId {
  OpKind kind = OpKind::Unary;
  int index = 0;  // the entry, for Unary and Binary
  bool operator==(const OpId& o) const { return kind == o.kind && index == o.index; }
  bool operator!=(const OpId& o) const { return !(*this == o); }
};

template <class Op, class... Ops>
constexpr int index_in(OpList<Ops...>) {
  int i = 0, found = -1;
  ((std::is_same_v<Op, Ops> ? (found = i, ++i) : ++i), ...);
  return found;
}

// The id of entry Op.
template <class Op>
constexpr OpId op_id() {
  constexpr int u = index_in<Op>(UnaryOps{}), b = index_in<Op>(BinaryOps{});
  static_assert(u >= 0 || b >= 0, "not an entry of the elementwise table");
  return u >= 0 ? OpId{OpKind::Unary, u} : OpId{OpKind::Binary, b};
}

// f(Op{}) for the entry at `index` of the list (nothing for an index outside it).
template <class... Ops, class F>
void visit_entry(OpList<Ops...>, int index, F&& f) {
  int i = 0;
  (void)((i++ == index ? (f(Ops{}), true) : false) || ...);
}

// Whether op's second operand gets the negated sum of g (sub).
inline bool negates_b(OpId op) {
  bool negate = false;
  if (op.kind == OpKind::Binary)
    visit_entry(BinaryOps{}, op.index, [&](auto entry) {
      if constexpr (decltype(entry)::linear) negate = decltype(entry)::negate_b;
    });
  return negate;
}

// Takes one operand (unary entries, Power, Clamp, Normalize) or two.
inline bool is_unary(OpId op) { return op.kind != OpKind::Binary && op.kind != OpKind::Dot; }

// The entry's name ("mul"); Power, Clamp, Dot and Normalize: "pow", "clamp", "dot", "normalize".
const char* op_name(OpId op);

// The eager op of a table entry (what its public function, e.g. mul, calls);
// b is ignored for unary entries. For tests that walk the table.
Tensor eager_op(OpId op, const Tensor& a, const Tensor& b = Tensor());

}  // namespace gr::detail
