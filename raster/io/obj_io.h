// Wavefront OBJ files: load_obj reads positions, normals and texture
// coordinates (through tinyobjloader, after a strict line check of our own) and
// returns a single-indexed Mesh; save_obj writes one back. Polygons are
// triangulated by gradraster itself (see load_obj), so triangle ids are stable
// and documented: tools that map rendered triangle ids back to OBJ faces rely
// on it.
#pragma once

#include <string>

#include "raster/mesh.h"

namespace gr::raster {

// Loads an OBJ file.
//  - Triangles: faces in file order; an n-gon becomes n-2 triangles in place
//    (a fan from its first corner if convex, ear clipping otherwise), keeping the
//    file's winding. Triangle k is the k-th triangle in that order.
//  - Vertices: one per distinct (position, texcoord, normal) index triple used
//    by a face, ordered by position index (the order of `v` lines), then
//    texcoord, then normal index. Positions no face uses are dropped (counted in
//    a warning). A file written with one index per vertex (as save_obj writes)
//    therefore loads back in the same vertex order.
//  - Normals / uvs are present only if every face corner names one; otherwise
//    they are dropped with a warning.
//  - texture_path: the map_Kd of the first material (in face order) that has
//    one, resolved relative to the OBJ's folder; set only if the file exists.
//    A missing MTL file or texture is a warning in Mesh::warnings, not an error.
// Files (the OBJ, its MTL files) are read with raster::read_input_file: regular
// files only (a symlink to one is fine), at most kMaxInputFileBytes; a texture
// that exists but is not a regular file is an error. An MTL file named by
// several mtllib lines (x.mtl, ./x.mtl, a link to it) is read once.
// Throws IOError naming the path (and line) for a missing/unreadable file or
// one that is not a regular file or too large, UTF-16 text or NUL bytes,
// malformed `v`/`vt`/`vn`/`f` lines (bad or missing numbers, non-finite or
// beyond-float values, faces with fewer than 3 or more than 255 corners,
// indices that are 0, malformed or refer to missing vertices), and for a file
// without any triangle. Bad tokens are quoted by their first 40 bytes.
// MemoryError, before parsing, if loading the text could exceed the memory
// budget (an upper bound from counts of its lines, raster/io/obj_memory.h), and
// before reading each MTL file's materials if they would not fit either (the
// message names the MTL file). Lines other than v, vt, vn, f, usemtl and
// mtllib are ignored; at most 20 of the OBJ parser's warnings are kept.
Mesh load_obj(const std::string& path);

// load_obj on OBJ text held in memory, with the same rules and errors; `name`
// stands in for the path in messages and warnings. No file is read: mtllib
// lines are ignored, so materials and texture_path stay empty.
Mesh load_obj_from_string(const std::string& text, const std::string& name = "<string>");

// Writes `mesh` as v / vt / vn / f lines (float values printed to round-trip
// exactly). If mesh.texture_path is set, also writes "<stem>.mtl" next to the
// OBJ with one material whose map_Kd points at the texture. Both files are
// written as one raster::OutputSet: an error leaves neither, and a target that
// is not a regular file is refused.
// Validates the mesh first (ShapeError/DTypeError/ValueError/IndexError).
void save_obj(const std::string& path, const Mesh& mesh);

}  // namespace gr::raster
