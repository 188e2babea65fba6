// Everything a user needs: tensors, the tape, gradcheck, Adam and all ops.
#pragma once

#include "autodiff/gradcheck.h"
#include "autodiff/optim.h"
#include "autodiff/parallel.h"
#include "autodiff/tape.h"
#include "autodiff/tensor.h"
#include "ops/antialias.h"
#include "ops/visibility_antialias.h"
#include "ops/batch.h"
#include "ops/channel.h"
#include "ops/cube_texture.h"
#include "ops/elementwise.h"
#include "ops/factories.h"
#include "ops/fragments.h"
#include "ops/interpolate.h"
#include "ops/linalg.h"
#include "ops/project.h"
#include "ops/promote.h"
#include "ops/depth_peel.h"
#include "ops/rasterize.h"
#include "ops/reduce.h"
#include "ops/resample.h"
#include "ops/map_rows.h"
#include "ops/mesh.h"
#include "ops/shading.h"
#include "ops/shape_ops.h"
#include "ops/soft_rasterize.h"
#include "ops/ssr.h"
#include "ops/texture.h"
#include "ops/transforms.h"
#include "ops/vector.h"

namespace gr {
// Kernel-side types that the ops' results and options carry, so an ops user
// never needs to spell gr::raster:: (Cull, Filter, Wrap and the SSR options
// are exported by their op headers).
using raster::AntialiasStats;    // AntialiasOptions::stats
using raster::EdgeTopology;      // what AntialiasTopology points to
using raster::kBackgroundDepth;  // GBuffer::depth of uncovered pixels
using raster::RasterStats;       // GBuffer::stats
using raster::SsrStats;          // the SSR results' stats
}  // namespace gr
