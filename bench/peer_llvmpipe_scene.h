// Scenes for the llvmpipe peer comparison: the meshes (the glmark2 bunny and
// its subdivisions, or procedural stand-ins) and one perspective camera per
// mesh, applied once on the CPU so both rasterizers get the same clip-space
// float vertices.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"
#include "raster/mesh.h"

namespace peer {

struct Scene {
  std::string name;
  gr::Tensor clip;       // N x 4 float32, OpenGL clip space
  gr::Tensor triangles;  // M x 3 int32
};

constexpr const char* kDefaultBunny = "/usr/share/glmark2/models/bunny.obj";

// The meshes of the comparison: a 10k-triangle torus, the base mesh, and the
// base mesh subdivided once (x4) and twice (x16, ~1.1M triangles for the
// bunny). The base mesh is `mesh_path` if given, else the glmark2 bunny if
// present, else an icosphere (81920 triangles); `notes` says which. Only the
// scenes whose name `wanted` accepts are built.
std::vector<Scene> make_scenes(const std::string& mesh_path,
                               const std::function<bool(const std::string&)>& wanted,
                               std::vector<std::string>* notes);

}  // namespace peer
