// stb_image, compiled here rather than taken from libstb, for two reasons
// (issue 30): only the formats gradraster documents are built (the HDR
// decoder, which loops forever on a truncated file, and GIF, PNM, PSD, PIC are
// left out), and its allocations go through counted_malloc/realloc/free below,
// which refuse to hold more than the limit of the decode in progress. A refused
// allocation makes stb fail cleanly ("outofmem"); decode_image then reports
// it as a MemoryError. The functions are static to this file (STB_IMAGE_STATIC),
// so they do not clash with libstb's (the tests and bench_png use its
// stb_image_write; the library writes PNG with raster/io/png_encoder.h).
#include "raster/io/image_decoder.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/io/image_io.h"

namespace gr::raster {
namespace {

// The limit of the decode running on this thread, and what it holds.
struct Allowance {
  explicit Allowance(std::size_t limit_bytes) : limit(limit_bytes) {
    static thread_local std::uint64_t decodes = 0;
    id = ++decodes;
  }
  std::uint64_t id = 0;
  std::size_t limit = 0;
  std::size_t held = 0;
  bool refused = false;
};
// Each block starts with its size and its allowance's id (16 bytes, which
// keeps malloc's alignment); freeing it gives the bytes back to that allowance
// only if it is still the one in force (the returned pixels are freed later).
struct BlockHeader {
  std::size_t size;
  std::uint64_t owner;
};
static_assert(sizeof(BlockHeader) == 16);
thread_local Allowance* t_allowance = nullptr;

// Installs `a` for the calls made in its scope.
struct AllowanceScope {
  explicit AllowanceScope(Allowance& a) { t_allowance = &a; }
  ~AllowanceScope() { t_allowance = nullptr; }
  AllowanceScope(const AllowanceScope&) = delete;
  AllowanceScope& operator=(const AllowanceScope&) = delete;
};

constexpr std::size_t kHeaderBytes = sizeof(BlockHeader);

BlockHeader header_of(void* p) {
  BlockHeader h;
  std::memcpy(&h, static_cast<char*>(p) - kHeaderBytes, sizeof h);
  return h;
}

void* start_block(char* raw, std::size_t n) {
  const BlockHeader h{n, t_allowance->id};
  std::memcpy(raw, &h, sizeof h);
  return raw + kHeaderBytes;
}

// True if `more` bytes may be held on top of what the allowance holds now.
bool may_hold(std::size_t more) {
  Allowance* a = t_allowance;
  if (!a) return false;  // stb is only called with an allowance installed
  if (more > a->limit - a->held || more > SIZE_MAX - kHeaderBytes) {
    a->refused = true;
    return false;
  }
  return true;
}

void* counted_malloc(std::size_t n) {
  if (!may_hold(n)) return nullptr;
  auto* p = static_cast<char*>(std::malloc(n + kHeaderBytes));
  if (!p) return nullptr;
  t_allowance->held += n;
  return start_block(p, n);
}

void counted_free(void* p) {
  if (!p) return;
  const BlockHeader h = header_of(p);
  if (t_allowance && h.owner == t_allowance->id) t_allowance->held -= h.size;
  std::free(static_cast<char*>(p) - kHeaderBytes);
}

// Counted as if the old and the new block were both held, as they may be.
void* counted_realloc(void* p, std::size_t n) {
  if (!p) return counted_malloc(n);
  const std::size_t old = header_of(p).size;
  if (n > old && !may_hold(n)) return nullptr;
  auto* q = static_cast<char*>(std::realloc(static_cast<char*>(p) - kHeaderBytes, n + kHeaderBytes));
  if (!q) return nullptr;
  t_allowance->held = t_allowance->held - old + n;
  return start_block(q, n);
}

}  // namespace
}  // namespace gr::raster

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_ONLY_BMP
#define STBI_ONLY_TGA
#define STBI_NO_STDIO
#define STBI_NO_LINEAR
#define STBI_MAX_DIMENSIONS gr::raster::kMaxImageSide
#define STBI_MALLOC(n) gr::raster::counted_malloc(n)
#define STBI_REALLOC(p, n) gr::raster::counted_realloc(p, n)
#define STBI_FREE(p) gr::raster::counted_free(p)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

namespace gr::raster {
namespace {

// Room for stb's header parsers (the largest is its JPEG decoder state).
constexpr std::size_t kHeaderAllowance = std::size_t(4) << 20;

std::string decoder_reason() {
  const char* why = stbi_failure_reason();
  return why && *why ? why : "no reason given";
}

std::string mib(std::size_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

std::uint32_t big_endian32(std::string_view b, std::size_t at) {
  std::uint32_t x = 0;
  for (std::size_t i = 0; i < 4; ++i) x = x << 8 | static_cast<std::uint8_t>(b[at + i]);
  return x;
}

// A PNG's size from its IHDR chunk, read here because stb refuses PNGs of more
// than 2^30 samples without saying their size ("unknown image type"). False if
// the first chunk is not an IHDR.
bool png_ihdr_size(std::string_view b, ImageHeader* h) {
  if (b.size() < 33 || b.substr(12, 4) != "IHDR") return false;
  const std::uint32_t w = big_endian32(b, 16), ht = big_endian32(b, 20);
  const int depth = static_cast<std::uint8_t>(b[24]), colour = static_cast<std::uint8_t>(b[25]);
  const int channels[7] = {1, 0, 3, 3, 2, 0, 4};  // by colour type; a palette decodes to RGB
  if (colour > 6 || channels[colour] == 0) return false;
  h->width = static_cast<int>(std::min<std::uint32_t>(w, INT32_MAX));
  h->height = static_cast<int>(std::min<std::uint32_t>(ht, INT32_MAX));
  h->channels = channels[colour];
  h->sixteen_bit = depth == 16;
  return true;
}

}  // namespace

void DecodedPixels::Free::operator()(void* p) const { stbi_image_free(p); }

void check_decodable_size(const ImageHeader& header, int channels, const std::string& what) {
  const std::string size = std::to_string(header.width) + " x " + std::to_string(header.height) + " pixels";
  if (header.width < 1 || header.height < 1 || header.width > kMaxImageSide || header.height > kMaxImageSide)
    throw IOError(what + ": the header says " + size + "; each side must lie in 1.." + std::to_string(kMaxImageSide));
  const int c = std::max(header.channels, channels);
  const std::size_t bytes = static_cast<std::size_t>(header.width) * static_cast<std::size_t>(header.height) *
                            static_cast<std::size_t>(c) * (header.sixteen_bit ? 2 : 1);
  if (bytes > kMaxDecodedImageBytes)
    throw IOError(what + ": the header says " + size + " x " + std::to_string(c) + " channels" +
                  (header.sixteen_bit ? " of 16 bits" : "") + ", " + std::to_string(bytes) +
                  " bytes decoded; at most " + std::to_string(kMaxDecodedImageBytes) + " bytes (1 GiB) are decoded");
}

ImageHeader decode_image_header(std::string_view bytes, const std::string& what) {
  if (bytes.size() > static_cast<std::size_t>(INT32_MAX)) throw IOError(what + ": file too large for the image decoder");
  Allowance allowance(kHeaderAllowance);
  AllowanceScope scope(allowance);
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int size = static_cast<int>(bytes.size());
  ImageHeader h;
  if (!stbi_info_from_memory(data, size, &h.width, &h.height, &h.channels)) {
    const std::string reason = decoder_reason();
    ImageHeader png;
    if (png_ihdr_size(bytes, &png)) check_decodable_size(png, 0, what);
    throw IOError(what + ": truncated or corrupt header (decoder: " + reason + ")");
  }
  h.sixteen_bit = stbi_is_16_bit_from_memory(data, size) != 0;
  return h;
}

DecodedPixels decode_image(std::string_view bytes, const ImageHeader& header, int channels,
                           std::size_t allocation_limit, const std::string& what) {
  Allowance allowance(allocation_limit);
  DecodedPixels out;
  {
    AllowanceScope scope(allowance);
    const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
    const int size = static_cast<int>(bytes.size());
    int file_channels = 0;
    stbi_set_flip_vertically_on_load_thread(0);  // row 0 stays the top row
    out.samples.reset(header.sixteen_bit
                          ? static_cast<void*>(stbi_load_16_from_memory(data, size, &out.width, &out.height,
                                                                        &file_channels, channels))
                          : static_cast<void*>(stbi_load_from_memory(data, size, &out.width, &out.height,
                                                                     &file_channels, channels)));
    out.channels = channels ? channels : file_channels;
  }
  // The pixels outlive the allowance: freeing them must not count against it.
  if (!out.samples && allowance.refused)
    throw MemoryError(what + ": decoding its " + std::to_string(header.width) + " x " + std::to_string(header.height) +
                      " pixels needed more than the " + mib(allocation_limit) +
                      " the memory budget leaves (memory limit " + mib(memory_limit()) +
                      "); compressed data that expands far beyond the size in the header means a corrupt file, "
                      "otherwise raise the limit with GRADRASTER_MEMORY_LIMIT or gr::set_memory_limit()");
  if (!out.samples)
    throw IOError(what + ": truncated or corrupt image data (decoder: " + decoder_reason() + ")");
  if (out.width != header.width || out.height != header.height)
    throw IOError(what + ": the decoded image is " + std::to_string(out.width) + " x " + std::to_string(out.height) +
                  " pixels, but the header says " + std::to_string(header.width) + " x " +
                  std::to_string(header.height));
  return out;
}

}  // namespace gr::raster
