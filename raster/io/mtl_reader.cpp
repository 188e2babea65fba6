// The MTL reader of mtl_reader.h.
#include "raster/io/mtl_reader.h"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <string_view>

#include "autodiff/base/memory.h"
#include "raster/io/files.h"
#include "raster/io/obj_lines.h"
#include "raster/io/obj_memory.h"
#include "raster/io/text_stream.h"

namespace gr::raster {
namespace {

// The "not found" warnings written, at most (obj_memory.cpp counts them).
constexpr int kMaxMissingWarnings = 8;

enum class MtlLine { Other, NewMaterial, DiffuseMap };

// The lines tinyobjloader's LoadMtl reads as "newmtl NAME" and "map_Kd
// [options] FILE" (leading spaces and tabs skipped).
MtlLine mtl_line_kind(std::string_view line) {
  const std::size_t i = std::min(line.find_first_not_of(" \t"), line.size());
  const std::string_view rest = line.substr(i);
  if (rest.size() <= 6 || (rest[6] != ' ' && rest[6] != '\t')) return MtlLine::Other;
  if (rest.substr(0, 6) == "newmtl") return MtlLine::NewMaterial;
  if (rest.substr(0, 6) == "map_Kd") return MtlLine::DiffuseMap;
  return MtlLine::Other;
}

MtlLineCounts count_mtl_lines(const std::string& text) {
  MtlLineCounts c;
  c.bytes = text.size();
  for_each_line(text, [&](std::size_t, std::string_view line) {
    const MtlLine kind = mtl_line_kind(line);
    const std::size_t kept = kind == MtlLine::Other ? 0 : line.size();
    c.parser_bytes += kept + 1;
    c.longest_kept_line = std::max(c.longest_kept_line, kept);
    c.materials += kind == MtlLine::NewMaterial;
  });
  return c;
}

// The MTL text the parser sees: kept lines as they are, others empty.
std::string mtl_parser_text(const std::string& text, std::size_t size) {
  std::string out;
  out.reserve(size);
  for_each_line(text, [&](std::size_t, std::string_view line) {
    if (mtl_line_kind(line) != MtlLine::Other) out += line;
    out += '\n';
  });
  return out;
}

}  // namespace

MtlReader::MtlReader(std::string obj_path, std::filesystem::path dir, std::size_t obj_bytes)
    : obj_path_(std::move(obj_path)), dir_(std::move(dir)), held_(obj_bytes) {}

bool MtlReader::operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                           std::map<std::string, int>* ids, std::string* warn, std::string*) {
  const std::string path = (dir_ / name).string();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 && (errno == ENOENT || errno == ENOTDIR)) {
    if (missing_ < kMaxMissingWarnings) *warn += "MTL file '" + path + "' not found\n";
    if (++missing_ == kMaxMissingWarnings) *warn += "further missing MTL files are not reported\n";
    return false;
  }
  // The same file named again (x.mtl, ./x.mtl, a link): its materials are there.
  if (!read_.insert({st.st_dev, st.st_ino}).second) return true;

  const std::string what = "load_obj('" + obj_path_ + "'): MTL file '" + path + "'";
  const std::string text = read_input_file(path, what);
  files_read_.push_back(path);
  const MtlLineCounts counts = count_mtl_lines(text);
  check_memory_request(held_ + mtl_held_bytes(counts) + mtl_parse_bytes(counts),
                       what + " (" + std::to_string(counts.bytes) + " bytes, " + std::to_string(counts.materials) +
                           " materials) with the OBJ");
  held_ += mtl_held_bytes(counts);
  const std::string kept = mtl_parser_text(text, counts.parser_bytes);
  TextStream in(kept);
  tinyobj::LoadMtl(ids, materials, &in, warn, nullptr);
  return true;
}

}  // namespace gr::raster
