// keep_resident / resident_of: the G-buffer's tensors stamped (ops/render/tensor_stamp.h).
#include "ops/render/resident_gbuffer.h"

namespace gr::detail {
std::shared_ptr<const ResidentGBuffer> keep_resident(std::vector<ResidentGBuffer::Image> images, const GBuffer& gb) {
  auto kept = std::make_shared<ResidentGBuffer>();
  kept->images = std::move(images);
  kept->tri_id = TensorStamp::of(gb.tri_id);
  kept->uv = TensorStamp::of(gb.uv);
  kept->depth = TensorStamp::of(gb.depth);
  kept->db = TensorStamp::of(gb.db);
  kept->clip = TensorStamp::of(gb.clip);
  kept->triangles = TensorStamp::of(gb.triangles);
  return kept;
}

std::shared_ptr<const ResidentGBuffer> keep_resident(std::shared_ptr<const raster::DeviceGBuffer> device,
                                                     const GBuffer& gb) {
  const std::int64_t count = gb.triangles.defined() ? gb.triangles.size(0) : 0;
  return keep_resident(std::vector<ResidentGBuffer::Image>{{std::move(device), 0, count}}, gb);
}

const ResidentGBuffer::Image* resident_image(const GBuffer& gb, std::int64_t b) {
  const ResidentGBuffer* r = gb.resident.get();
  if (!r || b < 0 || b >= static_cast<std::int64_t>(r->images.size()) || !r->images[b].device) return nullptr;
  const bool same = r->tri_id.matches(gb.tri_id) && r->uv.matches(gb.uv) && r->depth.matches(gb.depth) &&
                    r->db.matches(gb.db) && r->clip.matches(gb.clip) && r->triangles.matches(gb.triangles);
  return same ? &r->images[b] : nullptr;
}

const raster::DeviceGBuffer* resident_of(const GBuffer& gb) {
  const ResidentGBuffer::Image* image = resident_image(gb, 0);
  return image ? image->device.get() : nullptr;
}

ImageOnDevice image_on_device(const GBuffer* made, std::int64_t b, const Tensor& triangles,
                              const std::int32_t* tri_id, std::int64_t pixels, bool whole_list) {
  const ResidentGBuffer::Image* image = made ? resident_image(*made, b) : nullptr;
  return raster::image_on_device(image, triangles.data<std::int32_t>(), triangles.size(0), tri_id, pixels,
                                 whole_list);
}

}  // namespace gr::detail
