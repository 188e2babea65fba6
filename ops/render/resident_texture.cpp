// resident_texture: slots keyed by the backend, the tensors' storages and
// their write counts (Storage::version), the image and the levels.
#include "ops/render/resident_texture.h"

#include <algorithm>

namespace gr::detail {
namespace {

// A tensor's storage and write count when the slot was made.
struct Source {
  std::weak_ptr<Storage> storage;
  std::uint64_t version = 0;
  std::vector<std::int64_t> dims;
  DType dtype = DType::Float32;
};

Source source_of(const Tensor& t) { return {t.impl()->storage, t.impl()->storage->version(), t.shape().dims(), t.dtype()}; }

// t is the same storage as then, unwritten since, with the same shape.
bool unchanged(const Source& then, const Tensor& t) {
  const std::shared_ptr<Storage> s = then.storage.lock();
  return s && s == t.impl()->storage && s->version() == then.version && then.dims == t.shape().dims() &&
         then.dtype == t.dtype();
}

struct Entry {
  const raster::RasterBackend* backend = nullptr;
  std::int64_t image = 0;
  int levels = 0;
  Source tex;
  std::vector<Source> mip;
  std::shared_ptr<ResidentTexture> slot;
  std::uint64_t used = 0;
};

std::mutex g_mutex;
std::vector<Entry> g_entries;
std::uint64_t g_clock = 0;

bool matches(const Entry& e, const raster::RasterBackend* backend, const Tensor& tex, std::int64_t t, int levels,
             const std::vector<Tensor>& mip) {
  if (e.backend != backend || e.image != t || e.levels != levels || e.mip.size() != mip.size() ||
      !unchanged(e.tex, tex))
    return false;
  for (std::size_t i = 0; i < mip.size(); ++i)
    if (!unchanged(e.mip[i], mip[i])) return false;
  return true;
}

}  // namespace

std::shared_ptr<ResidentTexture> resident_texture(const raster::RasterBackend* backend, const Tensor& tex,
                                                  std::int64_t t, int levels, const std::vector<Tensor>& mip) {
  std::lock_guard<std::mutex> lock(g_mutex);
  for (Entry& e : g_entries)
    if (matches(e, backend, tex, t, levels, mip)) {
      e.used = ++g_clock;
      return e.slot;
    }
  // Entries whose tensors are gone or written since can never match again.
  g_entries.erase(std::remove_if(g_entries.begin(), g_entries.end(),
                                 [](const Entry& e) {
                                   const std::shared_ptr<Storage> s = e.tex.storage.lock();
                                   return !s || s->version() != e.tex.version;
                                 }),
                  g_entries.end());
  if (g_entries.size() >= static_cast<std::size_t>(kResidentTextureSlots))
    g_entries.erase(std::min_element(g_entries.begin(), g_entries.end(),
                                     [](const Entry& a, const Entry& b) { return a.used < b.used; }));
  Entry e;
  e.backend = backend;
  e.image = t;
  e.levels = levels;
  e.tex = source_of(tex);
  for (const Tensor& m : mip) e.mip.push_back(source_of(m));
  e.slot = std::make_shared<ResidentTexture>();
  e.used = ++g_clock;
  g_entries.push_back(e);
  return e.slot;
}

}  // namespace gr::detail
