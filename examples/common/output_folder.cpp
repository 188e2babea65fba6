#include "examples/common/output_folder.h"

#include "autodiff/base/error.h"

namespace gr::cli {
namespace fs = std::filesystem;

OutputFolder::~OutputFolder() {
  if (keep_) return;
  std::error_code ec;
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) fs::remove(*it, ec);  // fails if not empty
}

void OutputFolder::create() {
  std::error_code ec;
  // Remember which folders are missing, outermost first, before creating them.
  std::vector<fs::path> missing;
  for (fs::path p = fs::path(path_).lexically_normal(); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    missing.insert(missing.begin(), p);
    if (p == p.parent_path()) break;
  }
  // Registered before they exist: a signal from here on removes them (if empty).
  for (const fs::path& p : missing) registrations_.emplace_back(p.string(), raster::TemporaryKind::EmptyFolder);
  fs::create_directories(path_, ec);
  if (ec) throw IOError("cannot create output folder '" + path_ + "': " + ec.message());
  if (!fs::is_directory(path_, ec)) throw IOError("output folder '" + path_ + "' exists and is not a folder");
  created_ = missing;
}

void OutputFolder::keep() {
  keep_ = true;
  registrations_.clear();
}

}  // namespace gr::cli
