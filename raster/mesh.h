// Mesh: a single-indexed triangle mesh held in tensors, the common currency of
// the mesh loaders (obj_io.h), the procedural generators (procedural.h) and the
// renderers. Every vertex carries one position and, optionally, one normal and
// one texture coordinate; triangles index vertices 0-based, counter-clockwise
// when seen from the side the surface faces (outward normals on closed meshes).
//
//   Mesh m = make_icosphere(3);
//   m.validate("my_tool");   // throws a gr::Error naming the first problem
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::raster {

struct Mesh {
  Tensor positions;          // N×3 float32, finite
  Tensor triangles;          // M×3 int32, each index in [0, N)
  Tensor normals;            // N×3 float32, or undefined
  Tensor uvs;                // N×2 float32 (u right, v up: OBJ convention), or undefined
  std::string texture_path;  // diffuse map (MTL map_Kd), set only if the file exists
  std::vector<std::string> material_files;  // the MTL files load_obj read (inputs too)
  std::vector<std::string> warnings;  // non-fatal problems met while loading

  std::int64_t num_vertices() const { return positions.defined() ? positions.size(0) : 0; }
  std::int64_t num_triangles() const { return triangles.defined() ? triangles.size(0) : 0; }
  bool has_normals() const { return normals.defined(); }
  bool has_uvs() const { return uvs.defined(); }

  // Checks dtypes, shapes, finiteness of the float attributes and the range of
  // every triangle index. Throws DTypeError, ShapeError, ValueError or IndexError
  // whose message starts with `what` and names the offending field.
  void validate(const std::string& what) const;
};

}  // namespace gr::raster
