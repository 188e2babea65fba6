// The antialias walk's prefilter (issue 31): the pixels near a half-edge at
// which a surface walk (raster/detail/surface_walk.h) can end "Silhouette".
// A pair of neighbouring pixels neither of which is marked needs no walk.
// Internal to raster/.
//
// Why it is exact: a walk ends "Silhouette" at edge a-b of triangle t only if
// t's side is not 0, a and b are in front, and the neighbour across a-b is
// missing, degenerate or folds onto t's side (walk_surface's expressions,
// evaluated here by the same code into the same SurfaceSides memo). The exit
// point lies on the segment between the pair's two centres, so in the union
// of their pixel squares, and on the boundary of t, so on the screen segment
// a-b: one of the two squares touches a-b. That needs every point the walk
// passes to lie on the triangle it is in, which holds (up to rounding, which
// the margin covers) when the walk starts in the triangle the rasterizer
// found at that centre, every vertex is in front of the near plane, and
// neighbours share their edge on screen and no vertex is 2^36 px or more
// off the image; the mask is refused otherwise.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "raster/antialias.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/surface_walk.h"

namespace gr::raster::detail {

// Whether antialias_forward prefilters its walks: Auto decides per call
// (prefilter_pays); Never and Always are for tests comparing the two paths.
enum class SilhouettePrefilter { Auto, Never, Always };
extern std::atomic<SilhouettePrefilter> g_silhouette_prefilter;

// Walks skipped by the prefilter since the process started (tests read it).
extern std::atomic<std::int64_t> g_prefilter_skipped_walks;

// How far (pixels) beyond its square a pixel counts as touched by a segment.
constexpr double kSilhouetteMargin = 1.0 / 64.0;

// Pixel pairs (right and lower neighbours) whose triangle ids differ: the
// walks for_each_id_boundary would make (its own count, with nothing evaluated).
std::int64_t count_id_boundaries(const std::int32_t* tri_id, std::int64_t W, std::int64_t H);

// Whether prefiltering `candidates` walks over num_tris triangles costs less
// than walking them all: at least one candidate pair per triangle (measured
// in docs/performance.md).
bool prefilter_pays(std::int64_t candidates, std::int64_t num_tris);

// Marks (mask[p] = 1, W x H, zeroed by the caller) every pixel whose square,
// grown by kSilhouetteMargin, touches a half-edge at which a walk could end
// "Silhouette", storing the sides it computes in `sides`. Returns false, the
// mask unusable, when a triangle has a vertex behind the near plane or 2^36
// px or more off the image, or two neighbours' shared edge differs on screen
// (welded vertices apart).
bool build_silhouette_mask(const Vertices& v, const std::int32_t* tris, std::int64_t num_tris,
                           const EdgeTopology& topology, int W, int H, SurfaceSides& sides,
                           std::vector<std::atomic<std::uint8_t>>& mask);

}  // namespace gr::raster::detail
