// image_on_device: a range's copy read with the range's triangles and ids,
// or with the whole list and the range's first row.
#include "raster/image_on_device.h"

namespace gr::raster {

ImageOnDevice image_on_device(const KeptImage* kept, const std::int32_t* tris, std::int64_t num_tris,
                              const std::int32_t* tri_id, std::int64_t pixels, bool whole_list) {
  ImageOnDevice on;
  on.tris = tris;
  on.num_tris = num_tris;
  on.host_ids = tri_id;
  if (!kept || !kept->device) return on;
  on.device = kept->device.get();
  if (whole_list) {
    on.first = kept->first;
    return on;
  }
  if (kept->first == 0 && kept->count == num_tris) return on;
  // The range's triangles, ids numbered from 1 in it (0 stays background).
  on.tris += 3 * kept->first;
  on.num_tris = kept->count;
  const auto first = static_cast<std::int32_t>(kept->first);
  if (first != 0) {
    on.local_ids.resize(static_cast<std::size_t>(pixels));
    for (std::int64_t q = 0; q < pixels; ++q) on.local_ids[q] = tri_id[q] ? tri_id[q] - first : 0;
  }
  return on;
}

}  // namespace gr::raster
