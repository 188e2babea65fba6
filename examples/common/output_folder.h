// The folder a tool run writes its outputs into. create() makes it (and any
// missing parents); a run that fails before keep() removes the folders it
// created, so a failed run leaves no empty folder behind. Pair it with
// raster::OutputSet (or a staging folder) so no partial set of files appears.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace gr::cli {

class OutputFolder {
 public:
  explicit OutputFolder(std::string path) : path_(std::move(path)) {}
  ~OutputFolder();  // without keep(): removes the folders create() made, if empty
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // Throws IOError naming the path if it cannot be created or is not a folder.
  void create();
  void keep() { keep_ = true; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<std::filesystem::path> created_;  // outermost first
  bool keep_ = false;
};

}  // namespace gr::cli
