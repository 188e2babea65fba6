// The memory budget: how many bytes of tensor storage gradraster may hold.
//
// Every tensor buffer is counted (autodiff/base/storage.cpp). A request that would
// take the total past the limit throws MemoryError naming what was being
// allocated, before anything is allocated, so a render or a fit that cannot
// fit in memory fails at once with a clear message instead of exhausting the
// machine. Tools call check_memory_request() with their own estimate of a
// whole request (for example a 16384x16384 render) before starting it.
//
// The limit defaults to 3/4 of the machine's physical memory. The environment
// variable GRADRASTER_MEMORY_LIMIT (bytes, or with a K/M/G/T suffix, powers of
// 1024, optionally followed by B or iB) overrides the default; it is read when
// the limit is first needed and by set_memory_limit(0), and a malformed value
// throws ValueError naming it. set_memory_limit(bytes) overrides both.
//
// Freed memory is kept for reuse at two levels, because on virtual machines
// faulting in fresh pages can cost as much as the rendering (docs/performance.md,
// "Memory"): the storage cache (autodiff/base/storage.h) keeps tensor buffers, and
// tune_malloc() asks glibc's malloc to keep large freed blocks in its heap
// instead of mapping and unmapping them for every request.
#pragma once

#include <cstddef>
#include <string>

#include "autodiff/base/error.h"

namespace gr {

// The limit in force, in bytes.
std::size_t memory_limit();
// Sets the limit in bytes; 0 restores the default (environment, read again, else 3/4 of RAM).
void set_memory_limit(std::size_t bytes);
// Bytes of tensor storage currently held (live tensors and the reuse cache).
std::size_t memory_in_use();
// Throws MemoryError if `bytes` more would exceed the limit. `what` names the
// request in the message ("render 16384x16384", "texture 'wood.png'").
void check_memory_request(std::size_t bytes, const std::string& what);
// Parses a size such as "8G", "512M", "1048576"; throws ValueError naming `what`.
std::size_t parse_memory_size(const std::string& text, const std::string& what);

// Asks glibc's malloc (process-wide: it also serves the libraries in the process,
// torch's CPU tensors included) to serve blocks up to K bytes from its heap and to
// keep up to K bytes of free heap top for reuse, K = RAM / 16 between 32 MiB and
// 1 GiB. glibc's defaults map every block above 32 MiB afresh and unmap it on
// free, so a loop that allocates a 2048 x 2048 texture's gradient faults 48 MiB
// of new pages every iteration. The cost: the resident set stays near its peak
// (release_cached_storage() hands the free heap back). Applied once per process,
// by the first call (the storage cache's first use, `import gradraster.torch`);
// returns whether the settings are in force: false when the environment variable
// GRADRASTER_MALLOC_DEFAULTS is 1 (glibc's defaults kept), with another C library,
// or where the sanitizers' allocators ignore mallopt.
bool tune_malloc();

namespace detail {
// The error check_memory_request throws (also used by the storage cache).
MemoryError memory_limit_error(std::size_t bytes, const std::string& what, std::size_t used, std::size_t limit);
// Gives the cached tensor buffers back and throws MemoryError: `what` (an op)
// could not allocate scratch memory. Called by dispatch_float (autodiff/base/dtype.h).
[[noreturn]] void throw_allocation_failure(const std::string& what);
}  // namespace detail

}  // namespace gr
