// A 64-bit fingerprint of a tensor's bytes, for gradraster.torch's
// KeptTextures (python/gradraster/torch/_resident.py): a texture kept on a
// Vulkan device is read there again only while its tensors' fingerprints are
// the ones recorded when it was kept, so a write torch does not count
// (through .data or a numpy view) is seen and the texture uploaded.
//
// Not cryptographic: a change that keeps the value is astronomically unlikely
// by accident (about 2^-64 per changed texture), not impossible by design.
#pragma once

#include <cstddef>
#include <cstdint>

#include <pybind11/pybind11.h>

namespace gr::python {

// The fingerprint of n bytes at data (any alignment). The same value for any
// thread count: the bytes split into fixed chunks of kFingerprintChunk bytes,
// hashed in parallel, their hashes combined in chunk order.
constexpr std::int64_t kFingerprintChunk = std::int64_t(1) << 16;
std::uint64_t fingerprint_bytes(const void* data, std::int64_t n);

// _core.fingerprint(tensor, threads): the fingerprint of a C-contiguous
// float32, float64 or int32 tensor's bytes (python/src/array.h: ValueError for
// another layout, TypeError for another element type), hashed on `threads`
// threads with the GIL released.
std::uint64_t fingerprint(const pybind11::handle& tensor, int threads);

}  // namespace gr::python
