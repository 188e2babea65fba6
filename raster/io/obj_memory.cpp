// The memory bounds of obj_memory.h, term by term. Every term is what one
// allocation holds at most, read from tinyobjloader 2.0.0rc10 (LoadObj,
// exportGroupsToShape, LoadMtl) and from obj_io.cpp; the parser only sees the
// lines parser_text keeps (v, vt, vn, f, usemtl, mtllib; in MTL files newmtl
// and map_Kd), so no other line costs it anything. Two rules recur:
//  - kGrown: a std::vector or std::string grown one element at a time holds at
//    most twice its elements, and three times while it reallocates (the old
//    and the new buffer).
//  - kBlock: what malloc adds to a block (glibc: 8 bytes of header, rounding to
//    16, 32 bytes at least), at most.
//
// Loading OBJ text of B bytes has two phases, which do not overlap:
//  parse (inside tinyobj::LoadObj), per line kind:
//    v   3 floats (12 bytes) for the position and 3 for the optional colour,
//        each kGrown: 72 bytes
//    vt  2 floats, kGrown: 24;  vn  3 floats, kGrown: 36
//    f   of n corners: the face record (32 bytes, in a vector: kGrown) and its
//        corners (12 bytes each, one block); the flattened corners (12 bytes,
//        kGrown) and 9 bytes per face (corner count, material, smoothing group;
//        kGrown); the copy of the shape LoadObj returns (12 n + 9):
//        60 n + 164 bytes
//    usemtl / mtllib  their warnings ("material [ 'x' ] not found", 34 bytes
//        plus the name; "Failed to load material file(s)...", 56 bytes; the
//        MTL reader's "not found" lines, at most kMaxMtlWarnings), all in one
//        string: kGrown
//    one line at a time: the line (kGrown), the corners of a face being read
//        (12 bytes each, kGrown) or the names of an mtllib line (32 bytes each,
//        kGrown, one per 2 bytes): at most 64 bytes per byte of the longest line
//    and the parser's text (parser_bytes).
//  convert (triangulation, welding, tensors; the parser's temporaries are gone):
//    the parsed arrays (positions and colours 48 per v, 16 per vt, 24 per vn,
//    kGrown's factor 2 without the reallocation) and corners (12 per corner, 9
//    per face); per triangle 3 corner keys (36, reserved exactly), its material
//    (4), the weld's order, vertex and first-corner arrays (36), 8 per position
//    for the weld's buckets; the tensors: 32 bytes per welded vertex (position,
//    uv, normal; at most one per corner) and 12 per triangle, rounded up by at
//    most a quarter and 64 bytes to a storage bucket.
// The text itself (B) is held throughout. The sum gets an eighth more for
// what the derivation may miss (allocator rounding, a library's other copies).
//
// Per byte of text, the worst case is faces of 255 one-digit corners
// ("f 1 2 3 ... ", 512 bytes, 253 triangles): 30 bytes per byte in the parse
// phase, 51 in the convert phase, so 52 with the text and 58 with the margin
// (measured: 50, heap and tensors). Triangles "f 1 2 3" (8 bytes each) are
// estimated at 51 per byte (measured: 25), vertex lines "v 0 0 0" at 12.
#include "raster/io/obj_memory.h"

#include <tiny_obj_loader.h>

#include <algorithm>

namespace gr::raster {
namespace {

constexpr std::size_t kGrown = 3;
constexpr std::size_t kBlock = 32;
// Lines of "MTL file ... not found" the MTL reader writes (mtl_reader.h).
constexpr std::size_t kMaxMtlWarnings = 8;
// Fixed costs: a few dozen blocks, the end-of-file warnings, the capped list of
// warnings in the mesh.
constexpr std::size_t kFixed = std::size_t(64) << 10;

std::size_t parse_phase(const ObjLineCounts& c, std::size_t path_bytes) {
  const std::size_t one_line = 64 * c.longest_kept_line + 1024;
  const std::size_t attributes = 72 * c.v + 24 * c.vt + 36 * c.vn;
  const std::size_t faces = 60 * c.corners + 164 * c.faces;
  const std::size_t warnings =
      kGrown * (34 * c.usemtl + c.usemtl_bytes + 96 * c.mtllib +
                kMaxMtlWarnings * (path_bytes + c.longest_kept_line + 64));
  return c.parser_bytes + one_line + attributes + faces + warnings;
}

std::size_t convert_phase(const ObjLineCounts& c) {
  const std::size_t t = c.triangles();
  const std::size_t parsed = 48 * c.v + 16 * c.vt + 24 * c.vn + 12 * c.corners + 9 * c.faces;
  const std::size_t corners_and_weld = (36 + 4 + 36) * t + 8 * (c.v + 1);
  // A welded vertex is a distinct (position, uv, normal) triple of a corner.
  const std::size_t vt = std::max<std::size_t>(c.vt, 1), vn = std::max<std::size_t>(c.vn, 1);
  std::size_t welded = c.corners;
  if (c.v <= welded / vt / vn) welded = c.v * vt * vn;
  const std::size_t tensors = 32 * welded + 12 * t;
  return parsed + corners_and_weld + tensors + tensors / 4 + 4 * 64;
}

}  // namespace

std::size_t obj_load_bytes(const ObjLineCounts& counts, std::size_t path_bytes) {
  const std::size_t sum = counts.bytes + std::max(parse_phase(counts, path_bytes), convert_phase(counts)) + kFixed;
  return sum + sum / 8;
}

// Each material: the material_t record in LoadObj's vector (kGrown), its
// map entry (a tree node of about 80 bytes plus kBlock), and its strings (the
// name twice, the texture name once, each a block when longer than 15
// bytes): at most 3 bytes per byte of the kept lines plus 3 blocks.
std::size_t mtl_held_bytes(const MtlLineCounts& counts) {
  const std::size_t per_material = kGrown * sizeof(tinyobj::material_t) + 80 + kBlock + 3 * kBlock;
  return counts.materials * per_material + 3 * counts.parser_bytes;
}

// While an MTL file is parsed: its text, the kept lines, and one line at a
// time (the line kGrown, LoadMtl's copy of it, and the texture options of a
// map_Kd line: at most 8 bytes per byte of the longest line), plus LoadMtl's
// own material record.
std::size_t mtl_parse_bytes(const MtlLineCounts& counts) {
  return counts.bytes + counts.parser_bytes + 8 * counts.longest_kept_line + 2 * sizeof(tinyobj::material_t) +
         kFixed;
}

}  // namespace gr::raster
