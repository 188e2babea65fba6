// Cross-check of two G-buffers of the same clip-space mesh (ours and
// llvmpipe's, both in our conventions): how many pixels agree on tri_id, how
// far u, v and depth differ where they agree, and why they disagree elsewhere.
#pragma once

#include <cstdint>
#include <vector>

namespace peer {

struct GBufferView {
  const std::int32_t* tri_id;  // H*W, 1-based, 0 = background
  const float* uv;             // H*W*2, or null to skip the uv comparison
  const float* depth;          // H*W, z_ndc
};

struct Agreement {
  std::int64_t either_covered = 0;  // pixels where at least one buffer has a triangle
  std::int64_t same_id = 0;
  std::int64_t only_a = 0, only_b = 0, different_id = 0;
  double max_du = 0, max_dv = 0, max_ddepth = 0;  // over covered pixels with the same id
  double mean_du = 0, mean_dv = 0;
  // Disagreeing pixels whose centre lies within kEdgeTolerance pixels of an
  // edge of either triangle (exact double math): coverage ties / vertex snapping.
  std::int64_t disagree_at_edge = 0;
  // The other disagreements: two triangles overlap the pixel; largest |z_a - z_b|
  // (both evaluated exactly at the pixel centre) among them: depth near-ties.
  std::int64_t disagree_inside = 0;
  double max_depth_gap_inside = 0;
  // Pixels given to a triangle whose exact edges put the centre more than
  // kEdgeTolerance outside it (would be a bug on either side; expected 0).
  std::int64_t disagree_outside = 0;
};

// llvmpipe snaps vertices to 1/256 pixel, moving an edge by up to ~0.003 px.
constexpr double kEdgeTolerance = 1.0 / 128.0;

// clip: N x 4, tris: M x 3 (all vertices with w > 0 expected), width x height.
Agreement compare_gbuffers(const float* clip, const std::int32_t* tris, int width, int height,
                           const GBufferView& a, const GBufferView& b);

}  // namespace peer
