// The strict line check and the parser's text (see obj_lines.h).
#include "raster/io/obj_lines.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/io/files.h"

namespace gr::raster {
namespace {

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& msg) {
  throw IOError("load_obj('" + path + "'): line " + std::to_string(line) + ": " + msg);
}

std::string_view without_comment(std::string_view line) { return line.substr(0, std::min(line.find('#'), line.size())); }

// Enough tokens for a key and the most corners a face may have, plus one to
// tell that there are more; a longer line is refused by its count alone, so
// its tokens need not be kept.
constexpr std::size_t kMaxKeptTokens = kMaxFaceCorners + 2;

// Splits a line (comment removed) into tokens separated by spaces and tabs;
// keeps the first kMaxKeptTokens in `out` and returns how many there are.
std::size_t split_tokens(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  line = without_comment(line);
  std::size_t count = 0, i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) {
      if (out.size() < kMaxKeptTokens) out.push_back(line.substr(i, j - i));
      ++count;
    }
    i = j;
  }
  return count;
}

// A whole token as a finite number, or false.
bool parse_number(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
  double x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  // Positions, normals and uvs are stored as float: the value must fit one.
  return ec == std::errc() && end == s.data() + s.size() &&
         std::fabs(x) <= std::numeric_limits<float>::max();
}

// A whole (possibly signed) decimal integer that fits in int, or false.
bool parse_index(std::string_view s, long* out) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
  int x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  *out = x;
  return !s.empty() && ec == std::errc() && end == s.data() + s.size();
}

struct IndexCheck {
  long num_v = 0, num_vt = 0, num_vn = 0;
  // Largest positive index per attribute and the line that used it; checked at
  // the end because tinyobjloader (and some exporters) allow forward references.
  std::array<long, 3> max_index{0, 0, 0};
  std::array<std::size_t, 3> max_line{0, 0, 0};
};

// Checks one face corner "v", "v/t", "v//n" or "v/t/n".
void check_corner(const std::string& path, std::size_t line, std::string_view tok, IndexCheck& c) {
  std::array<std::string_view, 3> parts;
  int nparts = 0;
  std::size_t start = 0;
  // Built only for a message: the token quoted by a bounded prefix.
  const auto corner = [&] { return "face corner " + quote_for_message(std::string(tok)); };
  for (;;) {
    const std::size_t slash = tok.find('/', start);
    if (nparts == 3) fail(path, line, corner() + " has more than 3 indices");
    parts[nparts++] = tok.substr(start, slash == std::string::npos ? slash : slash - start);
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  const long counts[3] = {c.num_v, c.num_vt, c.num_vn};
  const char* names[3] = {"vertex", "texcoord", "normal"};
  for (int k = 0; k < nparts; ++k) {
    if (k == 1 && parts[k].empty() && nparts == 3) continue;  // v//n
    long idx = 0;
    if (!parse_index(parts[k], &idx))
      fail(path, line, corner() + " has a malformed " + names[k] + " index");
    if (idx == 0) fail(path, line, corner() + " uses index 0 (OBJ is 1-based)");
    if (idx < 0 && counts[k] + idx < 0)
      fail(path, line, corner() + " refers to " + names[k] + " " +
                           std::to_string(idx) + " but only " + std::to_string(counts[k]) +
                           " precede it");
    if (idx > c.max_index[k]) {
      c.max_index[k] = idx;
      c.max_line[k] = line;
    }
  }
}

// Checks a v, vt or vn line of n numbers.
void check_numbers(const std::string& path, std::size_t line, std::string_view key,
                   const std::vector<std::string_view>& tok, std::size_t n) {
  const std::size_t lo = key == "vt" ? 1 : 3;
  const std::size_t hi = key == "v" ? 7 : 3;
  if (n < lo || n > hi)
    fail(path, line, "'" + std::string(key) + "' needs " + std::to_string(lo) +
                         (lo == hi ? "" : " to " + std::to_string(hi)) + " numbers, got " +
                         std::to_string(n) + " (truncated line?)");
  for (std::size_t i = 1; i <= n; ++i)
    if (!parse_number(tok[i]))
      fail(path, line, "'" + std::string(key) + "' has a bad, non-finite or out-of-float-range number " +
                           quote_for_message(std::string(tok[i])));
}

// What parser_text does with a line, by its first token.
enum class Kept { No, WithoutComment, Whole };

Kept kept(std::string_view line) {
  std::size_t i = 0;
  while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
  std::size_t j = i;
  while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '#') ++j;
  const std::string_view key = line.substr(i, j - i);
  if (key == "v" || key == "vt" || key == "vn" || key == "f") return Kept::WithoutComment;
  // tinyobjloader reads the whole line for these (names may hold a '#').
  if ((key == "usemtl" || key == "mtllib") && (j == line.size() || line[j] != '#')) return Kept::Whole;
  return Kept::No;
}

std::string_view kept_part(std::string_view line, Kept k) {
  return k == Kept::Whole ? line : k == Kept::WithoutComment ? without_comment(line) : std::string_view();
}

}  // namespace

ObjLineCounts check_obj_lines(const std::string& path, const std::string& text) {
  ObjLineCounts counts;
  counts.bytes = text.size();
  IndexCheck c;
  std::vector<std::string_view> tok;
  for_each_line(text, [&](std::size_t line_no, std::string_view line) {
    counts.lines = line_no;
    const std::size_t kept_bytes = kept_part(line, kept(line)).size();
    counts.parser_bytes += kept_bytes + 1;
    counts.longest_kept_line = std::max(counts.longest_kept_line, kept_bytes);

    const std::size_t ntok = split_tokens(line, tok);
    if (ntok == 0) return;
    const std::string_view key = tok[0];
    const std::size_t n = ntok - 1;
    if (key == "v" || key == "vt" || key == "vn") {
      check_numbers(path, line_no, key, tok, n);
      ++(key == "v" ? counts.v : key == "vt" ? counts.vt : counts.vn);
      (key == "v" ? c.num_v : key == "vt" ? c.num_vt : c.num_vn) += 1;
    } else if (key == "f") {
      if (n < 3)
        fail(path, line_no, "face has " + std::to_string(n) + " corners, needs at least 3");
      if (n > kMaxFaceCorners)
        fail(path, line_no, "face has " + std::to_string(n) + " corners; at most " +
                                std::to_string(kMaxFaceCorners) + " are supported (split the polygon)");
      for (std::size_t i = 1; i <= n; ++i) check_corner(path, line_no, tok[i], c);
      ++counts.faces;
      counts.corners += n;
    } else if (key == "usemtl") {
      ++counts.usemtl;
      counts.usemtl_bytes += line.size();
    } else if (key == "mtllib") {
      ++counts.mtllib;
    }
  });
  const long totals[3] = {c.num_v, c.num_vt, c.num_vn};
  const char* names[3] = {"vertex", "texcoord", "normal"};
  for (int k = 0; k < 3; ++k)
    if (c.max_index[k] > totals[k])
      fail(path, c.max_line[k], "face refers to " + std::string(names[k]) + " " +
                                    std::to_string(c.max_index[k]) + " but the file has only " +
                                    std::to_string(totals[k]));
  return counts;
}

std::string parser_text(const std::string& text) {
  std::string out;
  std::size_t size = 0;
  for_each_line(text, [&](std::size_t, std::string_view line) { size += kept_part(line, kept(line)).size() + 1; });
  out.reserve(size);
  for_each_line(text, [&](std::size_t, std::string_view line) {
    out += kept_part(line, kept(line));
    out += '\n';
  });
  return out;
}

}  // namespace gr::raster
