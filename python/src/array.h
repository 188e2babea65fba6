// Typed views of the tensors the Python layer hands to gradraster._core.
//
// Every tensor argument of a _core function is a Python object that exports
// DLPack (`__dlpack__()`: a torch.Tensor without grad, e.g. `t.detach()`, or
// a numpy array), or None where the argument is optional. The function takes
// the view at the start of the call (an Array), and the view holds the DLPack
// capsule, which holds the producer's tensor (torch: the detached alias and
// its storage) until the Array is destroyed, after the kernels have run. So
// no memory a kernel reads can be freed by the Python side while it reads:
// the caller may drop every reference it has the moment the call starts.
// (As with torch's own ops, a second Python thread that resizes or writes a
// tensor in place while a call runs on it is a data race the caller must not
// create: the views pin the storage object, not its size.)
//
// The checks the kernels rely on all live here and in the _core functions:
// device (CPU), element type, C-contiguity, alignment, rank, shape, the
// shapes of related arguments, and that outputs overlap no other argument.
// A raw DLPack capsule is refused (it could have been made before the tensor
// changed), as is a raw address. Errors are gr errors: TypeError for a wrong
// kind or element type, ValueError for a wrong shape or layout.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

#include <pybind11/pybind11.h>

namespace gr::python {

// The element types the kernels read.
enum class Elem { F32, F64, I32 };
const char* elem_name(Elem e);

template <class T>
constexpr Elem elem_of();
template <>
constexpr Elem elem_of<float>() { return Elem::F32; }
template <>
constexpr Elem elem_of<double>() { return Elem::F64; }
template <>
constexpr Elem elem_of<std::int32_t>() { return Elem::I32; }

class Array {
 public:
  Array() = default;  // absent
  // obj: None (absent; refused unless `optional`) or an object with
  // __dlpack__() exporting a C-contiguous, aligned CPU tensor of float32,
  // float64 or int32. `op` and `name` label every error.
  Array(const pybind11::handle& obj, std::string op, std::string name, bool optional = false);
  // Views hold a Python object: created and destroyed with the GIL held
  // (before and after a KernelCall), so they move but never copy.
  Array(Array&&) noexcept = default;
  Array& operator=(Array&&) noexcept = default;
  Array(const Array&) = delete;
  Array& operator=(const Array&) = delete;

  bool present() const { return present_; }
  explicit operator bool() const { return present_; }
  Elem elem() const { return elem_; }
  int dim() const { return static_cast<int>(shape_.size()); }
  // Size of dimension i (negative: from the end).
  std::int64_t size(int i) const { return shape_[static_cast<std::size_t>(i < 0 ? dim() + i : i)]; }
  const std::vector<std::int64_t>& shape() const { return shape_; }
  std::int64_t numel() const;
  const std::string& name() const { return name_; }

  // The data as T (checked against the element type; null when absent).
  template <class T>
  const T* in() const {
    return static_cast<const T*>(typed(elem_of<T>()));
  }
  template <class T>
  T* out() const {
    return static_cast<T*>(typed(elem_of<T>()));
  }

  // Checks, each a no-op when absent. Element type: one of `allowed`
  // (TypeError), or `other`'s (TypeError naming both).
  const Array& elem_in(std::initializer_list<Elem> allowed) const;
  const Array& floating() const { return elem_in({Elem::F32, Elem::F64}); }
  const Array& same_elem(const Array& other) const;
  // Rank in `ranks` (ValueError).
  const Array& rank(std::initializer_list<int> ranks) const;
  // Exactly this shape; -1 matches any size (ValueError, naming `what`
  // when given, e.g. "[minibatch_size, height, width, 4]").
  const Array& shape(const std::vector<std::int64_t>& want, const char* what = nullptr) const;
  // Present (ValueError saying `why`).
  const Array& required(const char* why = nullptr) const;

  // [lo, hi) of the bytes viewed.
  const char* begin() const { return static_cast<const char*>(data_); }
  const char* end() const;

 private:
  void* typed(Elem want) const;
  std::string label() const;

  pybind11::object capsule_;  // holds the producer's tensor while the view lives
  void* data_ = nullptr;
  bool present_ = false;
  Elem elem_ = Elem::F32;
  std::vector<std::int64_t> shape_;
  std::string op_, name_;
};

// "[2, 3, 4]".
std::string shape_string(const std::vector<std::int64_t>& shape);

// ValueError unless every written array overlaps no other argument (the
// kernels read inputs while writing outputs, and write each output once).
void check_disjoint(const char* op, std::initializer_list<const Array*> written,
                    std::initializer_list<const Array*> read);

}  // namespace gr::python
