// A default camera for a mesh: look at its bounding sphere from an oblique
// direction so that the whole mesh is in view. gradraster-render uses it when
// no camera is given, and the rasterizer benchmarks frame their meshes with it.
#pragma once

#include <array>

#include "raster/mesh.h"

namespace gr::examples {

struct MeshFraming {
  std::array<double, 3> centre{};  // centre of the bounding box (the look-at target)
  double radius = 0;               // half the box diagonal: a bounding sphere
  std::array<double, 3> eye{};     // centre + distance * (0.35, 0.25, 1) / |.|
  std::array<double, 3> up{0, 1, 0};
  double fov_y = 0.7;              // radians; the sphere touches the frustum
  double near = 0, far = 0;        // 0.5 (distance - radius), 2 (distance + radius)
};

// The framing of `mesh` (positions must be finite). Throws ValueError for what
// has nothing to frame: no vertices, or every vertex at one point (any extent
// above 0 is framed, however small: the framing scales with it). Values may be
// non-finite if the coordinates are near the float range: callers check.
MeshFraming frame_mesh(const raster::Mesh& mesh);

}  // namespace gr::examples
