// Fuzz bodies: decode the bytes, run the code under test, check the contract
// (fuzz_targets.h).
#include "fuzz/fuzz_targets.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"

namespace gr::fuzz {
namespace {

// Runs `body`; swallows gr::Error, turns any other exception into a
// FuzzContractViolation naming it. Clears the thread's tape either way.
// The longest error message the OBJ body accepts.
constexpr std::size_t kMaxMessageBytes = 512;

template <class F>
void run_checked(const char* target, F&& body) {
  struct TapeReset {
    ~TapeReset() { Tape::current().clear(); }
  } reset;
  try {
    body();
  } catch (const Error&) {
    // Expected rejection of bad input.
  } catch (const FuzzContractViolation&) {
    throw;
  } catch (const std::exception& e) {
    throw FuzzContractViolation(std::string(target) + ": non-gr exception: " + e.what());
  }
}

void require_finite(const Tensor& t, const char* what) {
  if (!t.defined()) return;
  const std::vector<double> v = t.to_vector();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      throw FuzzContractViolation(std::string("fuzz_rasterize_interpolate: ") + what + "[" +
                                  std::to_string(i) + "] = " + std::to_string(v[i]) + " is not finite");
}

// Largest input magnitude for which gradients must be finite. Tiny values
// (denormals, w -> 0) stay in: the adjoints guard their divisions for them.
constexpr double kModerate = 1e4;

bool moderate_values(const Tensor& t) {
  for (const double v : t.to_vector())
    if (!(std::fabs(v) <= kModerate)) return false;
  return true;
}

// Sequential reader of the byte layout documented in fuzz_targets.h.
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }

  std::uint32_t u32() {
    std::uint32_t x = 0;
    for (int i = 0; i < 4; ++i) x |= static_cast<std::uint32_t>(byte()) << (8 * i);
    return x;
  }

  double value(bool float64) {
    const std::uint8_t tag = byte();
    if (tag < 0xE0) return (tag - 112) / 32.0;
    if (tag >= 0xF0 && tag < 0xFF) return tag - 0xF7;
    switch (tag) {
      case 0xE0: return 0.0;
      case 0xE1: return -0.0;
      case 0xE2: return std::numeric_limits<double>::quiet_NaN();
      case 0xE3: return std::numeric_limits<double>::infinity();
      case 0xE4: return -std::numeric_limits<double>::infinity();
      case 0xE5: return 1e38;
      case 0xE6: return -1e38;
      case 0xE7: return 1e-40;  // float32 denormal
      case 0xE8: return -1e-40;
      case 0xE9: return std::numeric_limits<float>::max();
      case 0xEA: return 1e-30;
      case 0xEB: return 1e30;
      case 0xEC: return 1e300;   // Inf once stored as float32
      case 0xED: return 1e-310;  // float64 denormal, 0 as float32
      case 0xEE: return 1e6;
      case 0xEF: return -1e6;
      default: break;  // 0xFF: raw bits
    }
    if (float64) {
      const std::uint64_t lo = u32(), hi = u32();
      const std::uint64_t bits = lo | (hi << 32);
      double d;
      std::memcpy(&d, &bits, sizeof d);
      return d;
    }
    const std::uint32_t bits = u32();
    float f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
  }

  std::int32_t index(std::int32_t num_vertices) {
    const std::uint8_t tag = byte();
    if (tag < 0xF8) return num_vertices > 0 ? tag % num_vertices : tag;
    switch (tag) {
      case 0xF8: return -1;
      case 0xF9: return num_vertices;
      case 0xFA: return std::numeric_limits<std::int32_t>::min();
      case 0xFB: return std::numeric_limits<std::int32_t>::max();
      default: return static_cast<std::int32_t>(u32());
    }
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// Exact values stored in a tensor of `dtype` (so float32 cases keep their bits).
Tensor tensor_of(const std::vector<double>& values, const Shape& shape, DType dtype) {
  Tensor t = Tensor::empty(shape, dtype);
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (dtype == DType::Float64) t.data<double>()[i] = values[i];
    else t.data<float>()[i] = static_cast<float>(values[i]);
  }
  return t;
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t x) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(x >> (8 * i)));
}

void put_value(std::vector<std::uint8_t>& out, double v, bool float64) {
  out.push_back(0xFF);
  if (float64) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    put_u32(out, static_cast<std::uint32_t>(bits));
    put_u32(out, static_cast<std::uint32_t>(bits >> 32));
  } else {
    const float f = static_cast<float>(v);
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    put_u32(out, bits);
  }
}

}  // namespace

void fuzz_obj_loader(const std::uint8_t* data, std::size_t size) {
  run_checked("fuzz_obj_loader", [&] {
    const std::string text(reinterpret_cast<const char*>(data), size);
    raster::Mesh mesh;
    try {
      mesh = raster::load_obj_from_string(text, "fuzz");
    } catch (const Error& e) {
      // Messages quote a bounded, printable prefix of what they complain about.
      const std::string msg = e.what();
      if (msg.size() > kMaxMessageBytes)
        throw FuzzContractViolation("fuzz_obj_loader: a " + std::to_string(msg.size()) + "-byte message");
      for (const char c : msg)
        if (static_cast<unsigned char>(c) < 0x20 && c != '\n')
          throw FuzzContractViolation("fuzz_obj_loader: a message with control byte " +
                                      std::to_string(static_cast<unsigned char>(c)));
      throw;
    }
    // load_obj validates before returning; a loaded mesh must pass again and
    // hold at least one triangle.
    mesh.validate("fuzz_obj_loader");
    if (mesh.num_triangles() < 1)
      throw FuzzContractViolation("fuzz_obj_loader: loaded a mesh without triangles");
  });
}

void fuzz_image_reader(const std::uint8_t* data, std::size_t size) {
  struct LimitReset {
    LimitReset() { set_memory_limit(memory_in_use() + (std::size_t(64) << 20)); }
    ~LimitReset() { set_memory_limit(0); }
  } limit;
  run_checked("fuzz_image_reader", [&] {
    const Tensor image = raster::read_image_from_memory(std::string(reinterpret_cast<const char*>(data), size), "fuzz");
    if (image.dtype() != DType::Float32 || image.rank() != 3 || image.size(2) < 1 || image.size(2) > 4)
      throw FuzzContractViolation("fuzz_image_reader: an image " + image.describe());
    const float* v = image.data<float>();
    for (std::int64_t i = 0; i < image.numel(); ++i)
      if (!(v[i] >= 0.0f && v[i] <= 1.0f))
        throw FuzzContractViolation("fuzz_image_reader: value " + std::to_string(v[i]) + " outside [0, 1]");
  });
}

void fuzz_rasterize_interpolate(const std::uint8_t* data, std::size_t size) {
  run_checked("fuzz_rasterize_interpolate", [&] {
    Reader in(data, size);
    const std::uint8_t flags = in.byte();
    const bool float64 = flags & 1;
    const DType dtype = float64 ? DType::Float64 : DType::Float32;
    RasterizeOptions ropt;
    ropt.cull = static_cast<Cull>(((flags >> 1) & 3) % 3);
    ropt.width = in.byte() % 16 + 1;
    ropt.height = in.byte() % 16 + 1;
    const std::int32_t n = in.byte() % 16;
    const std::int32_t m = in.byte() % 16;
    const std::int64_t c = in.byte() % 4 + 1;

    std::vector<double> clip_values(4 * n);
    for (double& v : clip_values) v = in.value(float64);
    std::vector<std::int32_t> tri_values(3 * m);
    for (std::int32_t& t : tri_values) t = in.index(n);
    std::vector<double> attr_values(n * c);
    for (double& v : attr_values) v = in.value(float64);
    std::vector<double> background_values(c);
    for (double& v : background_values) v = in.value(float64);
    const std::uint8_t seed_out = in.byte(), seed_depth = in.byte(), seed_uv = in.byte();

    Tensor clip = tensor_of(clip_values, {n, 4}, dtype).set_requires_grad();
    Tensor tris = Tensor::from_vector<std::int32_t>(tri_values, {m, 3});
    Tensor attributes = tensor_of(attr_values, {n, c}, dtype).set_requires_grad();
    InterpolateOptions iopt;
    ropt.derivatives = (flags & 8) || (flags & 16);  // interpolate_with_derivatives needs them
    if (flags & 32) iopt.background = tensor_of(background_values, {c}, dtype);

    // The G-buffer must be finite for any accepted input. Interpolated values,
    // screen derivatives and gradients may legitimately overflow when an input
    // is itself near the float range (a weighted sum of values near FLT_MAX,
    // rounding in the weights), so they are checked only for moderate inputs.
    const bool moderate = moderate_values(clip) && moderate_values(attributes);
    const GBuffer gb = rasterize(clip, tris, ropt);
    require_finite(gb.uv, "uv");
    require_finite(gb.depth, "depth");
    if (ropt.derivatives) require_finite(gb.db, "db");
    Tensor out;
    if (flags & 16) {
      const InterpolatedWithDerivatives d = interpolate_with_derivatives(attributes, gb, tris, iopt);
      if (moderate) {
        require_finite(d.d_dx, "d_dx");
        require_finite(d.d_dy, "d_dy");
      }
      out = d.values;
    } else {
      out = interpolate(attributes, gb, tris, iopt);
    }
    if (moderate) require_finite(out, "interpolated");

    // loss = <out, W1> + <depth, W2> + <uv, W3> with fixed random weights.
    auto weights = [&](const Tensor& t, std::uint8_t seed) {
      return Tensor::uniform(t.shape(), -1, 1, seed, dtype);
    };
    Tensor loss = sum(out * weights(out, seed_out)) + sum(gb.depth * weights(gb.depth, seed_depth)) +
                  sum(gb.uv * weights(gb.uv, seed_uv));
    if (ropt.derivatives) loss = loss + sum(gb.db * weights(gb.db, seed_uv));
    backward(loss);
    if (moderate) require_finite(clip.grad(), "clip.grad");
    if (moderate) require_finite(attributes.grad(), "attributes.grad");
  });
}

namespace {

// One extent per byte: < 0xF0 is the byte mod 8 (small, often 0 or 1);
// 0xF0.. are the extents that overflow products and byte counts.
std::int64_t decode_extent(std::uint8_t tag) {
  constexpr std::int64_t kHuge[] = {std::int64_t(1) << 31, std::int64_t(1) << 32, std::int64_t(1) << 40,
                                    std::int64_t(1) << 60, std::int64_t(1) << 61, std::int64_t(1) << 62,
                                    std::numeric_limits<std::int64_t>::max(), -1, -2,
                                    std::numeric_limits<std::int64_t>::min(), 3, 1000, 4096, 65536,
                                    (std::int64_t(1) << 31) - 1, std::int64_t(1) << 20};
  return tag < 0xF0 ? tag % 8 : kHuge[tag - 0xF0];
}

// A rank byte (mod 5) and one extent byte per axis.
std::vector<std::int64_t> decode_shape(Reader& in) {
  std::vector<std::int64_t> dims(in.byte() % 5);
  for (std::int64_t& d : dims) d = decode_extent(in.byte());
  return dims;
}

// The result must be as large as its extents say: write and read every element.
void require_consistent(const Tensor& t) {
  __int128 n = 1;
  for (int i = 0; i < t.rank(); ++i) n *= t.size(i);
  if (n != t.numel())
    throw FuzzContractViolation("fuzz_shapes: " + t.describe() + " reports " + std::to_string(t.numel()) +
                                " elements");
  Tensor c = t.copy();
  float* d = c.data<float>();
  for (std::int64_t i = 0; i < c.numel(); ++i) d[i] = 1.0f;
  double total = 0;
  for (std::int64_t i = 0; i < c.numel(); ++i) total += d[i];
  if (total != static_cast<double>(c.numel())) throw FuzzContractViolation("fuzz_shapes: buffer not writable");
}

}  // namespace

void fuzz_shapes(const std::uint8_t* data, std::size_t size) {
  struct LimitReset {
    LimitReset() { set_memory_limit(std::size_t(16) << 20); }
    ~LimitReset() { set_memory_limit(0); }
  } limit;
  run_checked("fuzz_shapes", [&] {
    Reader in(data, size);
    const int op = in.byte() % 7;
    const int axis = static_cast<int>(static_cast<std::int8_t>(in.byte()) % 6);
    const std::vector<std::int64_t> first = decode_shape(in), second = decode_shape(in);
    const Tensor a = Tensor::zeros(Shape(first));
    require_consistent(a);
    switch (op) {
      case 0: require_consistent(reshape(a, second)); break;
      case 1: require_consistent(broadcast_to(a, Shape(second))); break;
      case 2: require_consistent(concat({a, Tensor::zeros(Shape(second))}, axis)); break;
      case 3: require_consistent(stack({a, Tensor::zeros(Shape(second))}, axis)); break;
      case 4: require_consistent(matmul(a, Tensor::zeros(Shape(second)))); break;
      case 5: require_consistent(sum(a, axis)); break;
      default: require_consistent(slice(a, axis, second.empty() ? 0 : second[0], second.size() < 2 ? 1 : second[1]));
    }
  });
}

std::vector<std::uint8_t> encode_raster_case(const RasterCase& c) {
  std::vector<std::uint8_t> out;
  out.push_back(static_cast<std::uint8_t>((c.float64 ? 1 : 0) | (c.cull << 1) | (c.linear ? 8 : 0) |
                                          (c.with_derivatives ? 16 : 0) | (c.background ? 32 : 0)));
  const auto n = static_cast<std::uint8_t>(c.clip.size() / 4);
  const auto m = static_cast<std::uint8_t>(c.triangles.size() / 3);
  for (int b : {c.width - 1, c.height - 1, int{n}, int{m}, c.channels - 1}) out.push_back(static_cast<std::uint8_t>(b));
  for (double v : c.clip) put_value(out, v, c.float64);
  for (std::int32_t t : c.triangles) {
    out.push_back(0xFC);
    put_u32(out, static_cast<std::uint32_t>(t));
  }
  for (double v : c.attributes) put_value(out, v, c.float64);
  for (double v : c.background_values) put_value(out, v, c.float64);
  for (std::uint8_t seed : {1, 2, 3}) out.push_back(seed);
  return out;
}

}  // namespace gr::fuzz
