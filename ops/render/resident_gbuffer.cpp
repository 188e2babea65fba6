// keep_resident / resident_of: storages and their write counts (Storage::version).
#include "ops/render/resident_gbuffer.h"

namespace gr::detail {
namespace {

ResidentGBuffer::Source source_of(const Tensor& t) {
  if (!t.defined()) return {};
  return {true, t.impl()->storage, t.impl()->storage->version()};
}

// t is undefined and was, or is the same storage as then, unwritten since.
bool unchanged(const ResidentGBuffer::Source& then, const Tensor& t) {
  if (!t.defined() || !then.defined) return !t.defined() && !then.defined;
  const std::shared_ptr<Storage> s = then.storage.lock();
  return s && s == t.impl()->storage && s->version() == then.version;
}

}  // namespace

std::shared_ptr<const ResidentGBuffer> keep_resident(std::shared_ptr<const raster::DeviceGBuffer> device,
                                                     const GBuffer& gb) {
  auto kept = std::make_shared<ResidentGBuffer>();
  kept->device = std::move(device);
  kept->tri_id = source_of(gb.tri_id);
  kept->uv = source_of(gb.uv);
  kept->depth = source_of(gb.depth);
  kept->db = source_of(gb.db);
  kept->clip = source_of(gb.clip);
  kept->triangles = source_of(gb.triangles);
  return kept;
}

const raster::DeviceGBuffer* resident_of(const GBuffer& gb) {
  const ResidentGBuffer* r = gb.resident.get();
  if (!r || !r->device) return nullptr;
  const bool same = unchanged(r->tri_id, gb.tri_id) && unchanged(r->uv, gb.uv) && unchanged(r->depth, gb.depth) &&
                    unchanged(r->db, gb.db) && unchanged(r->clip, gb.clip) && unchanged(r->triangles, gb.triangles);
  return same ? r->device.get() : nullptr;
}

}  // namespace gr::detail
