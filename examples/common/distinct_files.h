// Outputs that would destroy an input or each other (issue 30, item 9). Every
// tool lists the files it reads and the files it will write and calls
// check_distinct_files before writing anything (and again once it knows the
// files an input pulls in, such as a mesh's texture). Two paths are the same
// file when they resolve to the same place (./v.obj, a/../v.obj, a symlink
// or a symlinked folder leading to v.obj) or, for files that exist, when
// they share device and inode (hard links, /dev/stdout and /dev/fd/1).
#pragma once

#include <string>
#include <vector>

namespace gr::cli {

struct NamedFile {
  std::string what;  // how messages name it: "--mesh", "--out-depth", "--out 'dir' (loss.png)"
  std::string path;
};

// Throws UsageError naming both sides if an output is the same file as an
// input ("refusing to overwrite an input") or as another output. Empty paths
// are skipped. Reads nothing and writes nothing.
void check_distinct_files(const std::vector<NamedFile>& inputs, const std::vector<NamedFile>& outputs);

// True if `a` and `b` name the same file (see above).
bool same_file(const std::string& a, const std::string& b);

}  // namespace gr::cli
