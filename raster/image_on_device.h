// One image's G-buffer kept on a backend's device (KeptImage) and what a call
// reading it hands the backend (image_on_device): the ops' batches
// (ops/render/resident_gbuffer.h) and the Python binding (python/src) share
// it. A range mode image's copy was rasterized from its range's triangles
// only, its ids numbered from 1 in the range, so a call reading the copy
// passes the range's triangles and the host's ids made local to it; or
// (antialias, whose edge topology indexes the whole list) the whole list, the
// host's ids and the range's first row, which the device adds to its ids.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "raster/backend.h"

namespace gr::raster {

// One image's copy (null: the backend made none) and the triangles it drew:
// rows first..first+count-1 of the caller's triangle list (a range mode
// image's range; all of them otherwise), its ids numbered from 1 in that
// range (the host's ids add `first`).
struct KeptImage {
  std::shared_ptr<const DeviceGBuffer> device;
  std::int64_t first = 0, count = 0;
};

// What a call hands the backend for one image: the device's copy and the
// triangles and ids it drew (a range's, ids made local to it), or no copy,
// all the triangles and the host's ids (the backend uploads them). Either way
// the same image for the kernels. With whole_list (image_on_device): the
// copy, all the triangles and the host's ids, and `first`, the row of the
// whole list the copy's triangle 0 is (its ids add first; 0 without a copy).
struct ImageOnDevice {
  const DeviceGBuffer* device = nullptr;
  std::int64_t first = 0;
  const std::int32_t* tris = nullptr;
  std::int64_t num_tris = 0;
  const std::int32_t* host_ids = nullptr;
  std::vector<std::int32_t> local_ids;  // made local, or empty
  const std::int32_t* ids() const { return local_ids.empty() ? host_ids : local_ids.data(); }
};

// kept: the image's copy, or null when the caller has none it still trusts
// (its host arrays changed since). tris, num_tris: the caller's whole list;
// tri_id: the image's host ids (pixels of them), indexing all of it.
// whole_list: keep the whole list and the host's ids, and give the copy's
// first row (antialias, whose edge topology indexes all the triangles: the
// device reads the whole list with its ids offset by `first`).
ImageOnDevice image_on_device(const KeptImage* kept, const std::int32_t* tris, std::int64_t num_tris,
                              const std::int32_t* tri_id, std::int64_t pixels, bool whole_list);

}  // namespace gr::raster
