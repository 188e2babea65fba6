#include "examples/common/distinct_files.h"

#include <sys/stat.h>

#include <filesystem>

#include "examples/common/cli_args.h"  // UsageError

namespace gr::cli {
namespace {
namespace fs = std::filesystem;

// Where a path leads: its device and inode if it exists (symlinks followed),
// and its absolute path with every existing part resolved.
struct FileIdentity {
  bool exists = false;
  dev_t device = 0;
  ino_t inode = 0;
  fs::path resolved;
};

FileIdentity identify(const std::string& path) {
  FileIdentity id;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.device = st.st_dev;
    id.inode = st.st_ino;
  }
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec);
  id.resolved = ec ? fs::path(path).lexically_normal() : fs::weakly_canonical(absolute, ec);
  if (ec) id.resolved = absolute.lexically_normal();
  return id;
}

bool same(const FileIdentity& a, const FileIdentity& b) {
  if (a.exists && b.exists) return a.device == b.device && a.inode == b.inode;
  return a.resolved == b.resolved;
}

std::string describe(const NamedFile& f) { return f.what + " '" + f.path + "'"; }

}  // namespace

bool same_file(const std::string& a, const std::string& b) { return same(identify(a), identify(b)); }

void check_distinct_files(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs) {
  std::vector<FileIdentity> in, out;
  for (const NamedFile& f : inputs) in.push_back(identify(f.path));
  for (const NamedFile& f : outputs) out.push_back(identify(f.path));
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    if (outputs[o].path.empty()) continue;
    for (std::size_t i = 0; i < inputs.size(); ++i)
      if (!inputs[i].path.empty() && same(out[o], in[i]))
        throw UsageError(describe(outputs[o]) + " is the same file as " + describe(inputs[i]) +
                         ": refusing to overwrite an input");
    for (std::size_t p = 0; p < o; ++p)
      if (!outputs[p].path.empty() && same(out[o], out[p]))
        throw UsageError(describe(outputs[o]) + " is the same file as " + describe(outputs[p]) +
                         ": two outputs cannot share a file");
  }
}

}  // namespace gr::cli
