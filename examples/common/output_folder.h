// The folder a tool run writes its outputs into. create() makes it (and any
// missing parents); a run that fails before keep() removes the folders it
// created, so a failed run leaves no empty folder behind; so does a run ended
// by a signal (they are registered with raster/temporaries.h until keep()).
// Pair it with raster::OutputSet (or a staging folder) so no partial set of
// files appears.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "raster/temporaries.h"

namespace gr::cli {

class OutputFolder {
 public:
  explicit OutputFolder(std::string path) : path_(std::move(path)) {}
  ~OutputFolder();  // without keep(): removes the folders create() made, if empty
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // Throws IOError naming the path if it cannot be created or is not a folder.
  void create();
  void keep();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<std::filesystem::path> created_;  // outermost first
  std::vector<raster::TemporaryRegistration> registrations_;  // of created_, until keep()
  bool keep_ = false;
};

}  // namespace gr::cli
