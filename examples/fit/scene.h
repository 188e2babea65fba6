// The scenes the fit example optimizes: a textured reference object (the
// built-in lobed blob or a user's OBJ), the sphere the shape fit starts from,
// the cameras (each with a light that travels with it) and the background.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"
#include "examples/fit/geometry.h"
#include "examples/fit/shading.h"

namespace fit {

struct SceneOptions {
  int views = 6;
  std::string mesh_path;       // empty: the built-in object
  std::string texture_path;    // overrides the OBJ's map_Kd (used when the OBJ has uvs)
  int reference_subdivisions = 5;  // of the built-in object's icosphere
  int start_subdivisions = 4;      // of the start sphere
  double start_radius = 0.75;
};

struct Camera {
  Tensor view;        // [4, 4] world -> view (look_at)
  Tensor projection;  // [4, 4]
  Tensor light;       // [3] unit direction towards the light, world space
};

struct Scene {
  std::string name;
  SurfaceMesh reference;       // what the target images show
  Material reference_material; // a texture if the reference has uvs and one, else vertex colours
  SurfaceMesh start;           // the sphere the shape fit starts from (with uvs)
  std::vector<Camera> cameras;
  Tensor background;           // [3]
  std::vector<std::string> files_read;  // the mesh, its MTL files and the texture, when given
  // Problems that did not stop the run: the OBJ loader's warnings (a missing
  // MTL or texture, ...) and, when a texture was named but is not used, why
  // the reference wears the procedural pattern instead.
  std::vector<std::string> warnings;
};

// Throws gr::ValueError naming --texture if a texture is given (options.texture_path)
// for a mesh without texture coordinates, or without a mesh.
Scene make_scene(const SceneOptions& options);

// The built-in reference: an icosphere whose radius varies smoothly with
// direction (two lobes along y, a waist and bumps), scaled into the unit
// sphere. Star-shaped about the origin, so a sphere can morph into it.
SurfaceMesh make_builtin_object(int subdivisions);
// radius of the built-in object along unit direction (x, y, z), before the
// scaling into the unit sphere.
double builtin_radius(double x, double y, double z);
// Loads an OBJ and scales it into the unit sphere around its bounding-box
// centre; the texture its MTL names (empty if none was found), the loader's
// warnings and the MTL files it read go to the optional outputs.
SurfaceMesh load_reference_object(const std::string& path, std::string* texture_path,
                                  std::vector<std::string>* warnings = nullptr,
                                  std::vector<std::string>* material_files = nullptr);
// A procedural equirectangular texture [height, 2 height, 3]: wavy warm/cool
// latitude stripes with pale spots (what the built-in object wears).
gr::Tensor striped_texture(int height);
// Per-point colours [P, 3] with the same pattern, from each point's direction
// (for meshes without uvs).
gr::Tensor striped_colours(const Tensor& positions);
// `views` cameras circling the y axis at alternating heights, 3.2 units out.
std::vector<Camera> orbit_cameras(int views);

}  // namespace fit
