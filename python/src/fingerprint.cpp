#include "python/src/fingerprint.h"

#include <algorithm>
#include <cstring>
#include <vector>

#include "autodiff/base/parallel.h"
#include "python/src/array.h"
#include "python/src/common.h"

namespace gr::python {
namespace {

// Odd 64-bit multipliers: 2^64 / golden ratio, and the two of Stafford's
// variant 13 of MurmurHash3's finalizer (the splitmix64 mixer).
constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ull;
constexpr std::uint64_t kMix1 = 0xBF58476D1CE4E5B9ull;
constexpr std::uint64_t kMix2 = 0x94D049BB133111EBull;

// Independent accumulators per chunk: each round waits on its own lane's
// last multiply only, so four run side by side.
constexpr int kLanes = 4;
// Chunks one thread hashes before others are worth waking (512 KiB).
constexpr std::int64_t kChunksPerTask = 8;

std::uint64_t rotl(std::uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

// Multiply-xorshift finalizer: a bijection of 64-bit words whose every
// output bit depends on every input bit.
std::uint64_t mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * kMix1;
  z = (z ^ (z >> 27)) * kMix2;
  return z ^ (z >> 31);
}

// One word into a lane: acc <- rotl(acc + w k1, 31) k2. For a fixed acc a
// bijection of w (and for a fixed w of acc), so a lane whose words differ in
// exactly one place always ends different.
std::uint64_t absorb(std::uint64_t acc, std::uint64_t w) { return rotl(acc + w * kMix1, 31) * kGolden; }

std::uint64_t load(const unsigned char* p) {
  std::uint64_t w;
  std::memcpy(&w, p, sizeof w);  // any alignment
  return w;
}

// The hash of n bytes (at most kFingerprintChunk): word i goes to lane
// i mod 4; the last n mod 8 bytes, zero-padded, are one more word (the total
// length enters the final value, so padding is no ambiguity). The lanes are
// chained through the bijective mix in lane order.
std::uint64_t chunk_hash(const unsigned char* p, std::int64_t n) {
  std::uint64_t lane[kLanes] = {kGolden, kMix1, kMix2, kGolden ^ kMix1};
  const std::int64_t words = n / 8;
  std::int64_t i = 0;
  for (; i + kLanes <= words; i += kLanes)
    for (int j = 0; j < kLanes; ++j) lane[j] = absorb(lane[j], load(p + 8 * (i + j)));
  for (int j = 0; i < words; ++i, ++j) lane[j] = absorb(lane[j], load(p + 8 * i));
  if (const std::int64_t tail = n % 8) {
    std::uint64_t w = 0;
    std::memcpy(&w, p + 8 * words, static_cast<std::size_t>(tail));
    lane[words % kLanes] = absorb(lane[words % kLanes], w);
  }
  std::uint64_t h = 0;
  for (std::uint64_t l : lane) h = mix(h ^ l);
  return h;
}

}  // namespace

std::uint64_t fingerprint_bytes(const void* data, std::int64_t n) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  const std::int64_t chunks = (n + kFingerprintChunk - 1) / kFingerprintChunk;
  std::vector<std::uint64_t> hashes(static_cast<std::size_t>(chunks));
  parallel_for(0, chunks, kChunksPerTask, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      const std::int64_t lo = c * kFingerprintChunk;
      hashes[static_cast<std::size_t>(c)] = chunk_hash(bytes + lo, std::min(n - lo, kFingerprintChunk));
    }
  });
  // Chunk hashes chained in chunk order (mix is a bijection: one chunk's
  // change always changes the result), after the length.
  std::uint64_t h = mix(static_cast<std::uint64_t>(n) ^ kGolden);
  for (std::uint64_t c : hashes) h = mix(h ^ c);
  return h;
}

std::uint64_t fingerprint(const pybind11::handle& tensor, int threads) {
  Array t(tensor, "fingerprint", "tensor");
  const std::int64_t n = t.end() - t.begin();
  KernelCall call(threads);
  return fingerprint_bytes(t.begin(), n);
}

}  // namespace gr::python
