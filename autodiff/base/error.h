// Exception types thrown by gradraster. Every message names the operation and
// the offending argument, so a user can tell which call went wrong without a
// debugger.
#pragma once

#include <stdexcept>
#include <string>

namespace gr {

// Base class of every gradraster error.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Shapes that cannot be combined (broadcasting, matmul, attribute counts...).
struct ShapeError : Error {
  using Error::Error;
};
// A tensor of the wrong element type (e.g. float32 where int32 indices are expected).
struct DTypeError : Error {
  using Error::Error;
};
// An index outside the valid range (gather, triangle indices, axes).
struct IndexError : Error {
  using Error::Error;
};
// A value that is not acceptable: NaN/Inf input, non-positive size, bad option.
struct ValueError : Error {
  using Error::Error;
};
// Misuse of the gradient tape (backward twice, non-scalar loss without upstream gradient).
struct TapeError : Error {
  using Error::Error;
};
// A request that would take gradraster's tensor memory past its limit
// (autodiff/base/memory.h), or an allocation the system refused.
struct MemoryError : Error {
  using Error::Error;
};
// A file that cannot be read or written, or whose contents are malformed.
struct IOError : Error {
  using Error::Error;
};

}  // namespace gr
