// The scene the fit example optimizes: a reference object with per-vertex
// colours (the built-in bumpy, striped icosphere or a user's OBJ), the start
// point of the optimization (same triangles, grey colours, dented positions)
// and the cameras, each with a light that travels with it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/tensor.h"
#include "examples/fit/shading.h"
#include "raster/mesh.h"

namespace fit {

struct SceneOptions {
  int views = 6;
  std::string mesh_path;    // empty: the built-in object
  std::uint64_t seed = 1;   // of the dents in the start positions
  double dent_depth = 0.05; // largest start offset along the normal (object radius = 1)
};

struct Scene {
  std::string name;
  Tensor triangles;            // [M, 3] int32
  Tensor reference_positions;  // [N, 3] what the target images show
  Tensor reference_colours;    // [N, 3]
  Tensor start_positions;      // [N, 3] reference + smooth dents along the normals
  Tensor start_colours;        // [N, 3] grey
  std::vector<Camera> cameras;
};

Scene make_scene(const SceneOptions& options);

// A bumpy icosphere (2562 vertices, 5120 triangles) fitting in the unit sphere.
gr::raster::Mesh make_builtin_object();
// Loads an OBJ, welds vertices that share a position (so dents cannot tear
// uv seams open), drops triangles that collapse, and scales it into the unit
// sphere around its bounding-box centre.
gr::raster::Mesh load_reference_object(const std::string& path);
// Per-vertex colours [N, 3] from a procedural stripe pattern on the direction
// of each vertex seen from the origin.
gr::Tensor striped_colours(const Tensor& positions);
// `views` cameras circling the y axis at alternating heights, 3.2 units out.
std::vector<Camera> orbit_cameras(int views);

}  // namespace fit
