// Reads the MTL files an OBJ file names, for tinyobjloader (which calls it for
// each name on an mtllib line).
//
// Issue 30: tinyobjloader parsed the file again for every mtllib line naming it
// (also when spelled ./x.mtl or ././x.mtl) and kept every copy of every
// material, outside the memory budget: a 467-byte OBJ and a 2.9 MB MTL reached
// 7.7 GB. This reader parses each distinct file once (the same device and
// inode, whatever the path), counts what its materials hold in the memory
// budget on top of the OBJ's own estimate, and refuses an MTL file that does
// not fit with a MemoryError naming it. Only newmtl and map_Kd lines are
// handed to the parser: the diffuse texture is all load_obj reads.
#pragma once

#include <sys/types.h>

#include <tiny_obj_loader.h>

#include <cstddef>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace gr::raster {

class MtlReader : public tinyobj::MaterialReader {
 public:
  // MTL names are resolved in `dir`; `obj_path` names the OBJ in messages;
  // `obj_bytes` is the OBJ's own estimate (obj_load_bytes), counted first.
  MtlReader(std::string obj_path, std::filesystem::path dir, std::size_t obj_bytes);

  // A missing file is a warning (at most 8 are written) and returns false, so
  // tinyobjloader tries the line's next name. Throws IOError for a file that
  // cannot be read (read_input_file) and MemoryError for one that does not
  // fit in the memory budget.
  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* ids, std::string* warn, std::string* err) override;

  // The MTL files read, each once, as their paths were resolved.
  const std::vector<std::string>& files_read() const { return files_read_; }

 private:
  std::string obj_path_;
  std::filesystem::path dir_;
  std::size_t held_;  // the OBJ's estimate plus what the MTL files read so far hold
  std::set<std::pair<dev_t, ino_t>> read_;
  std::vector<std::string> files_read_;
  int missing_ = 0;
};

}  // namespace gr::raster
