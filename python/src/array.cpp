#include "python/src/array.h"

#include <algorithm>

#include "autodiff/base/error.h"

namespace py = pybind11;

namespace gr::python {
namespace {

// DLPack's ABI (github.com/dmlc/dlpack, include/dlpack/dlpack.h, v0.6 as
// torch 1.13 and numpy 1.24 export it): only the structs read here. The
// header is not a dependency of the build (Debian ships it with libtorch-dev
// only); the layout has been stable since DLPack 0.5.
struct DLDevice {
  std::int32_t device_type;  // kDLCPU = 1
  std::int32_t device_id;
};
struct DLDataType {
  std::uint8_t code;  // kDLInt = 0, kDLUInt = 1, kDLFloat = 2
  std::uint8_t bits;
  std::uint16_t lanes;
};
struct DLTensor {
  void* data;
  DLDevice device;
  std::int32_t ndim;
  DLDataType dtype;
  std::int64_t* shape;
  std::int64_t* strides;  // in elements; null = compact row-major
  std::uint64_t byte_offset;
};
struct DLManagedTensor {
  DLTensor dl_tensor;
  void* manager_ctx;
  void (*deleter)(DLManagedTensor*);
};
constexpr std::int32_t kDLCPU = 1;
constexpr std::uint8_t kDLInt = 0, kDLUInt = 1, kDLFloat = 2;

std::string dtype_string(const DLDataType& t) {
  const char* kind = t.code == kDLFloat ? "float" : t.code == kDLInt ? "int" : t.code == kDLUInt ? "uint" : nullptr;
  std::string s = kind ? kind + std::to_string(t.bits) : "DLPack type code " + std::to_string(t.code);
  if (t.lanes != 1) s += " x " + std::to_string(t.lanes) + " lanes";
  return s;
}

std::size_t elem_bytes(Elem e) { return e == Elem::F64 ? 8 : 4; }

}  // namespace

const char* elem_name(Elem e) {
  switch (e) {
    case Elem::F32: return "float32";
    case Elem::F64: return "float64";
    case Elem::I32: return "int32";
  }
  return "?";
}

std::string shape_string(const std::vector<std::int64_t>& shape) {
  std::string s = "[";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

Array::Array(const py::handle& obj, std::string op, std::string name, bool optional)
    : op_(std::move(op)), name_(std::move(name)) {
  if (obj.is_none()) {
    if (!optional) throw ValueError(label() + " is required (got None)");
    return;
  }
  if (PyCapsule_CheckExact(obj.ptr()))
    throw DTypeError(label() + ": pass the tensor itself, not a DLPack capsule (the view is taken when the call "
                     "starts)");
  if (!py::hasattr(obj, "__dlpack__"))
    throw DTypeError(label() + " must be a tensor exporting DLPack (a torch.Tensor, or a numpy array), got " +
                     std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  // A producer's own refusal (a tensor that requires grad, a read-only numpy
  // array) propagates as its Python exception.
  capsule_ = obj.attr("__dlpack__")();
  if (!PyCapsule_IsValid(capsule_.ptr(), "dltensor"))
    throw DTypeError(label() + ": __dlpack__() did not return an unused DLPack capsule");
  const auto* managed = static_cast<const DLManagedTensor*>(PyCapsule_GetPointer(capsule_.ptr(), "dltensor"));
  const DLTensor& t = managed->dl_tensor;
  if (t.device.device_type != kDLCPU)
    throw ValueError(label() + " is not in CPU memory (DLPack device type " + std::to_string(t.device.device_type) +
                     "); gradraster runs on the CPU");
  const DLDataType d = t.dtype;
  if (d.lanes == 1 && d.code == kDLFloat && d.bits == 32)
    elem_ = Elem::F32;
  else if (d.lanes == 1 && d.code == kDLFloat && d.bits == 64)
    elem_ = Elem::F64;
  else if (d.lanes == 1 && d.code == kDLInt && d.bits == 32)
    elem_ = Elem::I32;
  else
    throw DTypeError(label() + " has element type " + dtype_string(d) + "; the kernels read float32, float64 or "
                     "int32");
  if (t.ndim < 0 || (t.ndim > 0 && !t.shape)) throw ValueError(label() + ": malformed DLPack shape");
  shape_.assign(t.shape, t.shape + t.ndim);
  // C-contiguous: strides (if given) are the compact row-major ones, except
  // where they cannot matter (a dimension of size 1, or no elements at all).
  if (t.strides && numel() > 0) {
    std::int64_t expect = 1;
    for (int i = t.ndim - 1; i >= 0; --i) {
      if (shape_[i] != 1 && t.strides[i] != expect)
        throw ValueError(label() + " is not contiguous (shape " + shape_string(shape_) +
                         "); the kernels read dense row-major memory: pass a contiguous tensor");
      expect *= shape_[i];
    }
  }
  data_ = static_cast<char*>(t.data) + t.byte_offset;
  if (reinterpret_cast<std::uintptr_t>(data_) % elem_bytes(elem_) != 0)
    throw ValueError(label() + " is not aligned to its element size");
  if (!data_ && numel() > 0) throw ValueError(label() + " has no memory");
  present_ = true;
}

std::string Array::label() const { return op_ + ": '" + name_ + "'"; }

std::int64_t Array::numel() const {
  std::int64_t n = 1;
  for (std::int64_t s : shape_) n *= s;
  return n;
}

const char* Array::end() const {
  return begin() + static_cast<std::size_t>(numel()) * elem_bytes(elem_);
}

void* Array::typed(Elem want) const {
  if (!present_) return nullptr;
  if (want != elem_)  // the functions dispatch on the checked type: a bug here, not bad input
    throw Error(label() + ": internal error: read as " + elem_name(want) + " but it holds " + elem_name(elem_));
  return data_;
}

const Array& Array::elem_in(std::initializer_list<Elem> allowed) const {
  if (!present_ || std::find(allowed.begin(), allowed.end(), elem_) != allowed.end()) return *this;
  std::string want;
  for (Elem e : allowed) want += std::string(want.empty() ? "" : " or ") + elem_name(e);
  throw DTypeError(label() + " must have dtype " + want + ", got " + elem_name(elem_));
}

const Array& Array::same_elem(const Array& other) const {
  if (present_ && other.present_ && elem_ != other.elem_)
    throw DTypeError(label() + " has dtype " + elem_name(elem_) + " but '" + other.name_ + "' has " +
                     elem_name(other.elem_) + "; use one float dtype");
  return *this;
}

const Array& Array::rank(std::initializer_list<int> ranks) const {
  if (!present_ || std::find(ranks.begin(), ranks.end(), dim()) != ranks.end()) return *this;
  std::string want;
  for (int r : ranks) want += (want.empty() ? "" : " or ") + std::to_string(r) + "D";
  throw ValueError(label() + " must be " + want + ", got shape " + shape_string(shape_));
}

const Array& Array::shape(const std::vector<std::int64_t>& want, const char* what) const {
  if (!present_) return *this;
  bool ok = want.size() == shape_.size();
  for (std::size_t i = 0; ok && i < want.size(); ++i) ok = want[i] < 0 || want[i] == shape_[i];
  if (ok) return *this;
  std::string w = what ? std::string(what) : shape_string(want);
  throw ValueError(label() + " must have shape " + w + ", got " + shape_string(shape_));
}

const Array& Array::required(const char* why) const {
  if (!present_) throw ValueError(label() + " is required" + (why ? std::string(": ") + why : std::string()));
  return *this;
}

void check_disjoint(const char* op, std::initializer_list<const Array*> written,
                    std::initializer_list<const Array*> read) {
  auto overlap = [](const Array& a, const Array& b) {
    return a && b && a.numel() > 0 && b.numel() > 0 && a.begin() < b.end() && b.begin() < a.end();
  };
  for (auto w = written.begin(); w != written.end(); ++w) {
    for (auto o = std::next(w); o != written.end(); ++o)
      if (overlap(**w, **o))
        throw ValueError(std::string(op) + ": the outputs '" + (*w)->name() + "' and '" + (*o)->name() +
                         "' share memory");
    for (const Array* r : read)
      if (overlap(**w, *r))
        throw ValueError(std::string(op) + ": the output '" + (*w)->name() + "' shares memory with the input '" +
                         r->name() + "'");
  }
}

}  // namespace gr::python
