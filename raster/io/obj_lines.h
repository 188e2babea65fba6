// The OBJ loader's own pass over the text, before tinyobjloader sees it.
//
// tinyobjloader is lenient in ways that would hand garbage to a renderer (a bad
// number reads as 0, a missing coordinate reads as 0, an out-of-range face
// index is only a warning), and some lines cost it far more memory than their
// size (a 20-byte tag line "t a 8192/8192/8192" makes it allocate 320 KB). So
// check_obj_lines checks every v/vt/vn/f line and counts what the parser will
// hold, and parser_text keeps only the lines gradraster reads.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace gr::raster {

// The most corners of one face: tinyobjloader counts them in a byte.
constexpr std::size_t kMaxFaceCorners = 255;

// What check_obj_lines found, counted for the memory estimate (obj_memory.h).
struct ObjLineCounts {
  std::size_t bytes = 0;            // the whole text
  std::size_t lines = 0;
  std::size_t v = 0, vt = 0, vn = 0;
  std::size_t faces = 0, corners = 0;
  std::size_t usemtl = 0, usemtl_bytes = 0;  // lines, and their bytes
  std::size_t mtllib = 0;
  std::size_t parser_bytes = 0;     // size of parser_text(text)
  std::size_t longest_kept_line = 0;  // bytes, of the lines parser_text keeps
  std::size_t triangles() const { return corners - 2 * faces; }
};

// Calls f(line_number, line) for every line of `text` (numbered from 1); lines
// end in \n, \r\n or \r, as tinyobjloader reads them.
template <class F>
void for_each_line(std::string_view text, F&& f) {
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    std::size_t end = pos;
    while (end < text.size() && text[end] != '\n' && text[end] != '\r') ++end;
    f(++line_no, text.substr(pos, end - pos));
    pos = end + ((end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n') ? 2 : 1);
  }
}

// Checks every v/vt/vn/f line of `text` (`path` names it in messages): the
// count of numbers and that each is finite and fits a float, faces of 3 to
// kMaxFaceCorners corners, indices that are well formed, not 0 and refer to
// existing vertices. Throws IOError naming the path and the line at the first
// problem. Lines end in \n, \r\n or \r; '#' starts a comment.
ObjLineCounts check_obj_lines(const std::string& path, const std::string& text);

// The text tinyobjloader parses: v/vt/vn/f lines without their comments,
// usemtl and mtllib lines as they are, every other line left empty (so line
// numbers stay). Call it on text that check_obj_lines accepted.
std::string parser_text(const std::string& text);

}  // namespace gr::raster
