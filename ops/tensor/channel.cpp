#include "ops/tensor/channel.h"

#include <string>

#include "ops/tensor/shape_ops.h"

namespace gr {

Tensor channel(const Tensor& a, std::int64_t k) {
  if (!a.defined()) throw ValueError("channel: argument 'a' is an undefined tensor");
  if (a.rank() == 0) throw ShapeError("channel: argument 'a' must have a channel axis, got " + a.describe());
  const std::int64_t c = a.size(-1);
  if (k < -c || k >= c)
    throw IndexError("channel: channel " + std::to_string(k) + " is out of range for " + a.describe() + " (" +
                     std::to_string(c) + " channels)");
  const std::int64_t first = k < 0 ? k + c : k;
  return slice(a, -1, first, first + 1);
}

}  // namespace gr
