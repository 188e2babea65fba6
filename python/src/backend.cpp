#include "python/src/backend.h"

#include <string>

#include "autodiff/base/error.h"
#ifdef GRADRASTER_HAS_VULKAN
#include "raster/vulkan/backend.h"
#endif

namespace gr::python {

const DeviceGBuffers* check_kept(const DeviceGBuffers* kept, std::int64_t images, const char* op) {
  if (kept && static_cast<std::int64_t>(kept->images.size()) != images)
    throw ValueError(std::string(op) + ": 'kept' holds the G-buffers of " + std::to_string(kept->images.size()) +
                     " images but 'rast' has " + std::to_string(images));
  return kept;
}

raster::ImageOnDevice image_on_device(const DeviceGBuffers* kept, std::int64_t b, const std::int32_t* tris,
                                      std::int64_t num_tris, const std::int32_t* tri_id, std::int64_t pixels,
                                      bool whole_list) {
  return raster::image_on_device(kept ? &kept->image(b) : nullptr, tris, num_tris, tri_id, pixels, whole_list);
}

void keep_gbuffers(const Context& ctx, std::int64_t images) {
#ifdef GRADRASTER_HAS_VULKAN
  if (ctx.grow_frames && ctx.backend && images <= INT32_MAX)
    vulkan::reserve_frames(*ctx.backend, static_cast<int>(images));
#else
  (void)ctx, (void)images;
#endif
}

}  // namespace gr::python
