// Upper bounds of the memory load_obj needs, computed from counts of what the
// OBJ and MTL files hold, so that a file the memory budget cannot take is
// refused before it is parsed (issue 30: the former bound, 16 bytes per byte
// of OBJ text, was passed by faces of 255 corners that then needed 45 bytes
// per byte; MTL files were not counted at all). obj_memory.cpp derives each
// term from what tinyobjloader and load_obj allocate.
#pragma once

#include <cstddef>

#include "raster/io/obj_lines.h"

namespace gr::raster {

// Peak bytes of loading OBJ text with these counts, the text itself included,
// materials excluded (see mtl_held_bytes). `path_bytes`: the length of the
// OBJ's path, which every warning repeats.
std::size_t obj_load_bytes(const ObjLineCounts& counts, std::size_t path_bytes);

// What an MTL file holds, counted by the MTL reader (mtl_reader.h).
struct MtlLineCounts {
  std::size_t bytes = 0;              // the whole file
  std::size_t parser_bytes = 0;       // the lines handed to tinyobjloader
  std::size_t materials = 0;          // newmtl lines
  std::size_t longest_kept_line = 0;  // bytes
};

// Bytes the materials of an MTL file hold until load_obj returns.
std::size_t mtl_held_bytes(const MtlLineCounts& counts);
// Bytes held only while the MTL file is parsed (its text, the parser's line).
std::size_t mtl_parse_bytes(const MtlLineCounts& counts);

}  // namespace gr::raster
