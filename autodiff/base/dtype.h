// Element types a Tensor can hold and compile-time helpers to dispatch on them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"

namespace gr {

enum class DType : std::uint8_t { Float32, Float64, Int32 };

inline const char* dtype_name(DType t) {
  switch (t) {
    case DType::Float32: return "float32";
    case DType::Float64: return "float64";
    case DType::Int32: return "int32";
  }
  return "?";
}

inline std::size_t dtype_size(DType t) { return t == DType::Float64 ? 8 : 4; }

inline bool is_floating(DType t) { return t != DType::Int32; }

template <class T> struct dtype_of;
template <> struct dtype_of<float> { static constexpr DType value = DType::Float32; };
template <> struct dtype_of<double> { static constexpr DType value = DType::Float64; };
template <> struct dtype_of<std::int32_t> { static constexpr DType value = DType::Int32; };

// Runs f() and turns an allocation failure of its scratch memory
// (std::bad_alloc, or std::length_error from a std::vector) into a MemoryError
// naming `what`. dispatch_float runs every kernel through it; integer-only
// kernels (fragment planning, mesh topology) call it directly.
template <class F>
decltype(auto) guard_allocation(const std::string& what, F&& f) {
  try {
    return f();
  } catch (const std::bad_alloc&) {
    detail::throw_allocation_failure(what);
  } catch (const std::length_error&) {
    detail::throw_allocation_failure(what);
  }
}

// Calls f(T{}) with T = float or double matching `t`; throws DTypeError for int32.
// `what` names the op and argument for the message, e.g. "exp: argument 'a'".
template <class F>
decltype(auto) dispatch_float(DType t, const std::string& what, F&& f) {
  if (t != DType::Float32 && t != DType::Float64)
    throw DTypeError(what + " must be float32 or float64, got " + dtype_name(t));
  return guard_allocation(what, [&]() -> decltype(auto) {
    if (t == DType::Float32) return f(float{});
    return f(double{});
  });
}

}  // namespace gr
