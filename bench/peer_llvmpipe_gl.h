// Mesa llvmpipe through OSMesa as a G-buffer rasterizer, for the peer
// comparison in peer_llvmpipe.cpp (docs/peers.md). It renders the same
// clip-space vertices our rasterizer gets into an FBO holding what our
// G-buffer holds: tri_id (R32I, gl_PrimitiveID + 1), screen-space
// barycentrics u, v (RG32F, noperspective varyings) and depth (32F).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace peer {

// A read-back llvmpipe G-buffer in OUR conventions: row 0 at the top,
// uv interleaved, depth = z_ndc (GL stores (z_ndc + 1) / 2), background
// tri_id 0 / uv (0, 0) / depth 1.
struct GlGBuffer {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv;
  std::vector<float> depth;
};

class LlvmpipeRasterizer {
 public:
  // Sets LP_NUM_THREADS = lp_threads and GALLIUM_DRIVER = llvmpipe, then
  // creates an OSMesa GL 3.3 core context (legacy context as a fallback) and
  // a width x height FBO. Returns null and fills *error on failure.
  static std::unique_ptr<LlvmpipeRasterizer> create(int width, int height, int lp_threads,
                                                    std::string* error);
  ~LlvmpipeRasterizer();
  LlvmpipeRasterizer(const LlvmpipeRasterizer&) = delete;
  LlvmpipeRasterizer& operator=(const LlvmpipeRasterizer&) = delete;

  // "GL_RENDERER | GL_VERSION | context kind".
  std::string description() const;

  // Uploads once (outside any timing): a de-indexed copy (3 vertices per
  // triangle, for the full G-buffer) and the indexed mesh (for the id-only
  // pass). clip: N x 4 floats, tris: M x 3 indices.
  void upload(const float* clip, std::int64_t num_vertices, const std::int32_t* tris,
              std::int64_t num_tris);

  // Each runs clear + draw + glFinish, so the frame is complete on return.
  void draw_gbuffer();  // glDrawArrays on the de-indexed copy: tri_id, u, v, depth
  void draw_id_only();  // glDrawElements on the indexed mesh: tri_id, depth (no u, v)
  void clear_only();    // the clear + glFinish part alone

  // Reads back the attachments of the last draw (uv is zero after draw_id_only).
  GlGBuffer read_back() const;

 private:
  LlvmpipeRasterizer() = default;
  bool init(int width, int height, std::string* error);
  void clear();

  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace peer
