// resident_texture: slots keyed by the backend, the tensors' stamps
// (ops/render/tensor_stamp.h), the image, the levels and the kind.
#include "ops/render/resident_texture.h"

#include <algorithm>

#include "ops/render/tensor_stamp.h"

namespace gr::detail {
namespace {

struct Entry {
  const raster::RasterBackend* backend = nullptr;
  std::int64_t image = 0;
  int levels = 0;
  TextureKind kind = TextureKind::Plane;
  TensorStamp tex;
  std::vector<TensorStamp> mip;
  std::shared_ptr<ResidentTexture> slot;
  std::uint64_t used = 0;
};

std::mutex g_mutex;
std::vector<Entry> g_entries;
std::uint64_t g_clock = 0;

bool matches(const Entry& e, const raster::RasterBackend* backend, const Tensor& tex, std::int64_t t, int levels,
             const std::vector<Tensor>& mip, TextureKind kind) {
  if (e.backend != backend || e.image != t || e.levels != levels || e.kind != kind || e.mip.size() != mip.size() ||
      !e.tex.matches(tex))
    return false;
  for (std::size_t i = 0; i < mip.size(); ++i)
    if (!e.mip[i].matches(mip[i])) return false;
  return true;
}

}  // namespace

std::shared_ptr<ResidentTexture> resident_texture(const raster::RasterBackend* backend, const Tensor& tex,
                                                  std::int64_t t, int levels, const std::vector<Tensor>& mip,
                                                  TextureKind kind) {
  std::lock_guard<std::mutex> lock(g_mutex);
  for (Entry& e : g_entries)
    if (matches(e, backend, tex, t, levels, mip, kind)) {
      e.used = ++g_clock;
      return e.slot;
    }
  // Entries whose tensors are gone or written since can never match again.
  g_entries.erase(std::remove_if(g_entries.begin(), g_entries.end(),
                                 [](const Entry& e) {
                                   return e.tex.stale() ||
                                          std::any_of(e.mip.begin(), e.mip.end(),
                                                      [](const TensorStamp& m) { return m.stale(); });
                                 }),
                  g_entries.end());
  if (g_entries.size() >= static_cast<std::size_t>(kResidentTextureSlots))
    g_entries.erase(std::min_element(g_entries.begin(), g_entries.end(),
                                     [](const Entry& a, const Entry& b) { return a.used < b.used; }));
  Entry e;
  e.backend = backend;
  e.image = t;
  e.levels = levels;
  e.kind = kind;
  e.tex = TensorStamp::of(tex);
  for (const Tensor& m : mip) e.mip.push_back(TensorStamp::of(m));
  e.slot = std::make_shared<ResidentTexture>();
  e.used = ++g_clock;
  g_entries.push_back(e);
  return e.slot;
}

}  // namespace gr::detail
