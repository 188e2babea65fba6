// Element types a Tensor can hold and compile-time helpers to dispatch on them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>

#include "autodiff/error.h"
#include "autodiff/memory.h"

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

// Calls f(T{}) with T = float or double matching `t`; throws DTypeError for int32.
// `what` names the op and argument for the message, e.g. "exp: argument 'a'".
// Every op runs its kernels through here, so this is also where an allocation
// failure of a kernel's scratch memory (std::bad_alloc, or std::length_error
// from a std::vector) becomes a MemoryError naming the op.
template <class F>
decltype(auto) dispatch_float(DType t, const std::string& what, F&& f) {
  try {
    switch (t) {
      case DType::Float32: return f(float{});
      case DType::Float64: return f(double{});
      default: break;
    }
  } catch (const std::bad_alloc&) {
    detail::throw_allocation_failure(what);
  } catch (const std::length_error&) {
    detail::throw_allocation_failure(what);
  }
  throw DTypeError(what + " must be float32 or float64, got " + dtype_name(t));
}

}  // namespace gr
