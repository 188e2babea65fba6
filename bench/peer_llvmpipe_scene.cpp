#include "peer_llvmpipe_scene.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "ops/tensor/linalg.h"
#include "ops/render/transforms.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "mesh_framing.h"

namespace peer {

std::vector<Scene> make_scenes(const std::string& mesh_path,
                               const std::function<bool(const std::string&)>& wanted,
                               std::vector<std::string>* notes) {
  gr::raster::Mesh base;
  std::string base_name;
  const std::string path = mesh_path.empty() ? kDefaultBunny : mesh_path;
  if (!mesh_path.empty() || std::ifstream(path).good()) {
    base = gr::raster::load_obj(path);  // an explicit --mesh that fails to load is an error
    base_name = mesh_path.empty() ? "bunny" : "mesh";
    notes->push_back("base mesh: " + path);
  } else {
    base = gr::raster::make_icosphere(6);
    base_name = "icosphere6";
    notes->push_back(std::string("base mesh: ") + kDefaultBunny +
                     " not found (install glmark2-data); using procedural icospheres instead");
  }
  std::vector<Scene> scenes;
  auto add = [&](const std::string& name, const gr::raster::Mesh& m) {
    if (wanted(name)) scenes.push_back({name, gr::bench::frame_mesh(m), m.triangles});
  };
  add("torus-10k", gr::raster::make_torus(100, 50, 1.0f, 0.35f));
  add(base_name, base);
  if (!wanted(base_name + "-x4") && !wanted(base_name + "-x16")) return scenes;
  gr::raster::Mesh x4 = gr::raster::subdivide(base);
  add(base_name + "-x4", x4);
  if (wanted(base_name + "-x16")) add(base_name + "-x16", gr::raster::subdivide(x4));
  return scenes;
}

}  // namespace peer
