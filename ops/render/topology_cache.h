// The welded edge topology antialias and antialias_batch build for
// themselves (no AntialiasOptions::topology), kept for the next call
// (internal). A call on the same triangle tensor, unwritten since
// (ops/render/tensor_stamp.h), with the same vertex count, gets the same
// topology back (the same object, so the same serial: a device keeps its
// upload) while the weld it was built with still holds for the new clip rows
// (raster::weld_holds: the same vertices have equal rows; O(N), no sort);
// otherwise it is built again. The result is always the topology
// build_edge_topology gives for these rows, neighbour for neighbour.
// The last 4 welds are kept (24 bytes per triangle and 4 per vertex each);
// an entry whose triangles were freed or written goes at the next call.
#pragma once

#include <cstdint>

#include "autodiff/base/tensor.h"
#include "ops/render/antialias.h"

namespace gr::detail {

// triangles: validated [M, 3] int32 with indices in [0, num_vertices); rows:
// num_vertices x 4 finite clip rows. Thread-safe.
template <class T>
AntialiasTopology welded_topology(const Tensor& triangles, std::int64_t num_vertices, const T* rows);

}  // namespace gr::detail
