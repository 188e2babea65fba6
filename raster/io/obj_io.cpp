// OBJ loading and saving. tinyobjloader does the parsing, after load_obj has
// checked every line itself (obj_lines.h), estimated the memory the load needs
// (obj_memory.h) and kept only the lines it reads; MTL files are read by
// MtlReader (mtl_reader.h). tinyobjloader runs without triangulation; this
// file triangulates (fan for convex polygons, ear clipping otherwise) so
// triangle ids are predictable, then welds (v, vt, vn) index triples into a
// single-indexed Mesh.
#include "raster/io/obj_io.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <string_view>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/io/files.h"
#include "raster/io/mtl_reader.h"
#include "raster/io/obj_lines.h"
#include "raster/io/obj_memory.h"
#include "raster/io/text_stream.h"

namespace gr::raster {
namespace fs = std::filesystem;
namespace {

// Second line of defence after tinyobjloader: its reading of a line could
// differ from check_obj_lines' (before parser_text removed comments, "f 1 2
// 3#4 5" gave it a fourth corner "5"), so every index it returns is checked
// against what it parsed before anything is looked up.
void check_parsed_indices(const std::string& path, const tinyobj::attrib_t& attrib,
                          const std::vector<tinyobj::shape_t>& shapes) {
  const auto nv = static_cast<long>(attrib.vertices.size() / 3);
  const auto nt = static_cast<long>(attrib.texcoords.size() / 2);
  const auto nn = static_cast<long>(attrib.normals.size() / 3);
  for (const tinyobj::shape_t& shape : shapes) {
    std::size_t corners = 0;
    for (const unsigned int n : shape.mesh.num_face_vertices) corners += n;
    if (corners != shape.mesh.indices.size())
      throw IOError("load_obj('" + path + "'): inconsistent face data from the OBJ parser");
    for (const tinyobj::index_t& ix : shape.mesh.indices)
      if (ix.vertex_index < 0 || ix.vertex_index >= nv || ix.texcoord_index < -1 ||
          ix.texcoord_index >= nt || ix.normal_index < -1 || ix.normal_index >= nn)
        throw IOError("load_obj('" + path + "'): a face refers to a missing vertex, texcoord or "
                      "normal once parsed (stray characters such as '#' inside an 'f' line?)");
  }
}

// ---------------------------------------------------------------------------
// Triangulation of one polygon (corner positions given), emitting corner
// numbers 0..n-1 as triples that keep the polygon's winding.

using P3 = std::array<double, 3>;

void triangulate(const std::vector<P3>& p, std::vector<std::array<int, 3>>& out) {
  const int n = static_cast<int>(p.size());
  auto fan = [&](const std::vector<int>& idx) {
    for (std::size_t i = 1; i + 1 < idx.size(); ++i) out.push_back({idx[0], idx[i], idx[i + 1]});
  };
  std::vector<int> ring(n);
  std::iota(ring.begin(), ring.end(), 0);
  if (n == 3) return fan(ring);

  // Newell normal; project onto the plane of its largest component so that the
  // polygon runs counter-clockwise in 2D.
  P3 nrm{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const P3& a = p[i];
    const P3& b = p[(i + 1) % n];
    nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
    nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
    nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
  }
  int drop = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(nrm[k]) > std::fabs(nrm[drop])) drop = k;
  if (nrm[drop] == 0) return fan(ring);  // degenerate polygon
  const int ax = (drop + 1) % 3, ay = (drop + 2) % 3;
  const double flip = nrm[drop] > 0 ? 1.0 : -1.0;
  std::vector<std::array<double, 2>> q(n);
  for (int i = 0; i < n; ++i) q[i] = {p[i][ax], flip * p[i][ay]};
  auto cross = [&](int a, int b, int c) {
    return (q[b][0] - q[a][0]) * (q[c][1] - q[a][1]) - (q[b][1] - q[a][1]) * (q[c][0] - q[a][0]);
  };

  // Convex (no reflex corner): a fan from the first corner.
  bool convex = true;
  for (int i = 0; i < n && convex; ++i) convex = cross(i, (i + 1) % n, (i + 2) % n) >= 0;
  if (convex) return fan(ring);

  // Ear clipping: cut the first convex corner whose triangle holds no other corner.
  while (ring.size() > 3) {
    const int m = static_cast<int>(ring.size());
    bool cut = false;
    for (int i = 0; i < m && !cut; ++i) {
      const int a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (cross(a, b, c) <= 0) continue;
      bool empty = true;
      for (int j = 0; j < m && empty; ++j) {
        const int d = ring[j];
        if (d == a || d == b || d == c) continue;
        empty = !(cross(a, b, d) >= 0 && cross(b, c, d) >= 0 && cross(c, a, d) >= 0);
      }
      if (!empty) continue;
      out.push_back({a, b, c});
      ring.erase(ring.begin() + i);
      cut = true;
    }
    if (!cut) break;  // self-intersecting or degenerate: fan the rest
  }
  fan(ring);
}

// ---------------------------------------------------------------------------
// load_obj_text, phase by phase.

// Phase 0: OBJ is text; UTF-16 (a byte-order mark or NUL bytes) and binary
// files are refused with the line of the first NUL byte.
void check_encoding(const std::string& path, const std::string& text) {
  const bool bom16 = text.size() >= 2 && ((text[0] == '\xff' && text[1] == '\xfe') ||
                                          (text[0] == '\xfe' && text[1] == '\xff'));
  const std::size_t nul = text.find('\0');
  if (!bom16 && nul == std::string::npos) return;
  const std::size_t at = bom16 ? 0 : nul;
  const std::size_t line = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n'));
  throw IOError("load_obj('" + path + "'): line " + std::to_string(line) + ": " +
                (bom16 ? "starts with a UTF-16 byte-order mark" : "contains a NUL byte") +
                ": UTF-16 (or binary) files are not supported; save the OBJ as UTF-8 or ASCII");
}

struct ParsedObj {
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::vector<std::string> material_files;  // the MTL files read
};

// A line of tinyobjloader's (it can quote a whole line of the file) cut to a
// readable length, control bytes shown as '?'.
std::string readable(std::string_view line) {
  constexpr std::size_t kMaxWarning = 200;
  std::string cut(line.substr(0, kMaxWarning));
  if (line.size() > kMaxWarning) cut += "...";
  for (char& c : cut)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  return cut;
}

// tinyobjloader's warnings, one per line, made readable; at most
// kMaxParserWarnings of them (a file can make one per line), then a count of
// the others.
void add_warnings(const std::string& path, std::string_view text, std::vector<std::string>& out) {
  constexpr std::size_t kMaxParserWarnings = 20;
  std::size_t shown = 0, more = 0;
  for_each_line(text, [&](std::size_t, std::string_view line) {
    if (line.empty() || line == ".") return;
    if (shown == kMaxParserWarnings) return ++more, void();
    out.push_back("load_obj('" + path + "'): " + readable(line));
    ++shown;
  });
  if (more) out.push_back("load_obj('" + path + "'): " + std::to_string(more) + " more warnings of the OBJ parser");
}

// Phase 2: tinyobjloader (no triangulation, no vertex colours) on the lines
// load_obj reads; MTL files are read from `dir` only if it is given.
ParsedObj parse_with_tinyobj(const std::string& path, const std::string& text, const fs::path* dir,
                             std::size_t estimate, std::vector<std::string>& warnings) {
  ParsedObj obj;
  std::string warn, err;
  {
    const std::string kept = parser_text(text);
    TextStream stream(kept);
    MtlReader mtl_reader(path, dir ? *dir : fs::path(), estimate);
    const bool ok = tinyobj::LoadObj(&obj.attrib, &obj.shapes, &obj.materials, &warn, &err, &stream,
                                     dir ? &mtl_reader : nullptr, /*triangulate=*/false,
                                     /*default_vcols_fallback=*/false);
    if (!ok) throw IOError("load_obj('" + path + "'): " + (err.empty() ? "parse error" : readable(err)));
    obj.material_files = mtl_reader.files_read();
  }
  check_parsed_indices(path, obj.attrib, obj.shapes);
  add_warnings(path, warn, warnings);
  add_warnings(path, err, warnings);  // only MTL problems reach here when ok
  return obj;
}

using Key = std::array<int, 3>;  // (position, texcoord, normal), -1 = none

struct Corners {
  std::vector<Key> keys;          // three per output triangle
  std::vector<int> material_of;   // per output triangle
};

// Phase 3: triangulates every face in file order, collecting corner keys (an
// n-gon always gives n - 2 triangles: the arrays are sized exactly, as
// obj_memory.cpp counts them).
Corners triangulate_faces(const std::string& path, const ParsedObj& obj, const ObjLineCounts& lines) {
  Corners out;
  out.keys.reserve(3 * lines.triangles());
  out.material_of.reserve(lines.triangles());
  std::size_t faces = 0;
  std::vector<P3> poly;
  std::vector<std::array<int, 3>> tris;
  for (const tinyobj::shape_t& shape : obj.shapes) {
    std::size_t offset = 0;
    for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f, ++faces) {
      const int nv = shape.mesh.num_face_vertices[f];
      poly.resize(nv);
      for (int i = 0; i < nv; ++i) {
        const int vi = shape.mesh.indices[offset + i].vertex_index;
        for (int k = 0; k < 3; ++k) poly[i][k] = obj.attrib.vertices[3 * vi + k];
      }
      tris.clear();
      triangulate(poly, tris);
      for (const auto& t : tris) {
        for (int c : t) {
          const tinyobj::index_t& ix = shape.mesh.indices[offset + c];
          out.keys.push_back({ix.vertex_index, ix.texcoord_index, ix.normal_index});
        }
        out.material_of.push_back(shape.mesh.material_ids.empty() ? -1 : shape.mesh.material_ids[f]);
      }
      offset += nv;
    }
  }
  if (faces != lines.faces)
    throw IOError("load_obj('" + path + "'): tinyobjloader returned " + std::to_string(faces) +
                  " faces, the file has " + std::to_string(lines.faces));
  if (out.keys.empty()) throw IOError("load_obj('" + path + "'): no triangles (empty mesh)");
  return out;
}

// Phase 4: keeps uvs / normals only if every corner has one (else drops them
// from every key, with a warning). Returns {all corners have uvs, ... normals}.
std::array<bool, 2> keep_complete_attributes(const std::string& path, std::vector<Key>& keys,
                                             std::vector<std::string>& warnings) {
  bool all_uv = true, any_uv = false, all_n = true, any_n = false;
  for (const Key& k : keys) {
    all_uv &= k[1] >= 0, any_uv |= k[1] >= 0;
    all_n &= k[2] >= 0, any_n |= k[2] >= 0;
  }
  if (any_uv && !all_uv)
    warnings.push_back("load_obj('" + path + "'): some face corners lack texture "
                       "coordinates; uvs dropped");
  if (any_n && !all_n)
    warnings.push_back("load_obj('" + path + "'): some face corners lack normals; "
                       "normals dropped");
  for (Key& k : keys) {
    if (!all_uv) k[1] = -1;
    if (!all_n) k[2] = -1;
  }
  return {all_uv, all_n};
}

struct Welded {
  std::vector<std::int32_t> vertex_of;     // per corner
  std::vector<std::uint32_t> first_corner;  // one representative corner per vertex
};

// Phase 5: one vertex per distinct key, in key order. Corners are bucketed by
// position index (counting sort), then each small bucket is sorted by key.
Welded weld(const std::vector<Key>& corners, std::size_t num_positions) {
  std::vector<std::uint32_t> start(num_positions + 1, 0);
  for (const Key& k : corners) ++start[k[0] + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::uint32_t> order(corners.size());
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::uint32_t c = 0; c < corners.size(); ++c) order[fill[corners[c][0]]++] = c;
  }
  for (std::size_t v = 0; v < num_positions; ++v)
    if (start[v + 1] - start[v] > 1)
      std::sort(order.begin() + start[v], order.begin() + start[v + 1],
                [&](std::uint32_t a, std::uint32_t b) { return corners[a] < corners[b]; });
  Welded w;
  w.vertex_of.resize(corners.size());
  w.first_corner.reserve(corners.size());  // a vertex per corner at most (obj_memory.cpp)
  for (std::size_t i = 0; i < order.size(); ++i) {
    if (i == 0 || corners[order[i]] != corners[order[i - 1]]) w.first_corner.push_back(order[i]);
    w.vertex_of[order[i]] = static_cast<std::int32_t>(w.first_corner.size() - 1);
  }
  return w;
}

// Phase 6: the mesh tensors, with a warning for positions no face uses.
void fill_tensors(const std::string& path, const tinyobj::attrib_t& attrib, const std::vector<Key>& corners,
                  const Welded& welded, std::array<bool, 2> complete, Mesh& mesh) {
  const auto [all_uv, all_n] = complete;
  const auto nverts = static_cast<std::int64_t>(welded.first_corner.size());
  const auto ntris = static_cast<std::int64_t>(corners.size() / 3);
  mesh.positions = Tensor::empty({nverts, 3});
  mesh.triangles = Tensor::empty({ntris, 3}, DType::Int32);
  if (all_uv) mesh.uvs = Tensor::empty({nverts, 2});
  if (all_n) mesh.normals = Tensor::empty({nverts, 3});
  std::int64_t used_positions = 0;
  for (std::int64_t v = 0; v < nverts; ++v) {
    const Key& k = corners[welded.first_corner[v]];
    if (v == 0 || k[0] != corners[welded.first_corner[v - 1]][0]) ++used_positions;
    for (int c = 0; c < 3; ++c) mesh.positions.data<float>()[3 * v + c] = attrib.vertices[3 * k[0] + c];
    if (all_uv)
      for (int c = 0; c < 2; ++c) mesh.uvs.data<float>()[2 * v + c] = attrib.texcoords[2 * k[1] + c];
    if (all_n)
      for (int c = 0; c < 3; ++c) mesh.normals.data<float>()[3 * v + c] = attrib.normals[3 * k[2] + c];
  }
  std::copy(welded.vertex_of.begin(), welded.vertex_of.end(), mesh.triangles.data<std::int32_t>());
  const auto total_positions = static_cast<std::int64_t>(attrib.vertices.size() / 3);
  if (used_positions < total_positions)
    mesh.warnings.push_back("load_obj('" + path + "'): " +
                            std::to_string(total_positions - used_positions) +
                            " vertices are used by no face and were dropped");
}

// Resolves a texture name from an MTL file relative to `dir`; empty if absent.
// A name that exists but is not a regular file (FIFO, device) is an IOError.
std::string resolve_texture(const std::string& path, const fs::path& dir, std::string name) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    const fs::path p = dir / name;
    std::error_code ec;
    const fs::file_status st = fs::status(p, ec);  // follows symlinks, as for every input
    if (fs::is_regular_file(st)) return p.lexically_normal().string();
    if (fs::exists(st))
      throw IOError("load_obj('" + path + "'): texture '" + p.string() +
                    "' named by the MTL file is not a regular file");
    std::replace(name.begin(), name.end(), '\\', '/');  // files written on Windows
  }
  return {};
}

// Phase 7: the diffuse texture, the first material (in face order) that names one.
void pick_texture(const std::string& path, const fs::path* dir, const std::vector<tinyobj::material_t>& materials,
                  const std::vector<int>& material_of, Mesh& mesh) {
  std::string texname;
  std::vector<std::string> others;
  for (int m : material_of) {
    if (m < 0 || m >= static_cast<int>(materials.size())) continue;
    const std::string& t = materials[m].diffuse_texname;
    if (t.empty()) continue;
    if (texname.empty()) texname = t;
    else if (t != texname && std::find(others.begin(), others.end(), t) == others.end())
      others.push_back(t);
  }
  if (!texname.empty()) {
    if (dir) mesh.texture_path = resolve_texture(path, *dir, texname);
    if (mesh.texture_path.empty())
      mesh.warnings.push_back("load_obj('" + path + "'): texture " + quote_for_message(texname) +
                              " named by the MTL file not found");
  }
  if (!others.empty())
    mesh.warnings.push_back("load_obj('" + path + "'): faces use " +
                            std::to_string(others.size() + 1) +
                            " diffuse textures; only the first, " + quote_for_message(texname) +
                            ", is kept");
}

// Loads OBJ `text`; `path` names it in messages. With `dir` set, MTL files and
// textures are looked up in that folder; without it they are not read at all.
Mesh load_obj_text(const std::string& path, const std::string& text, const fs::path* dir) {
  check_encoding(path, text);
  const ObjLineCounts lines = check_obj_lines(path, text);
  const std::size_t estimate = obj_load_bytes(lines, path.size());
  check_memory_request(estimate, "load_obj('" + path + "') of " + std::to_string(text.size()) + " bytes (" +
                                     std::to_string(lines.v) + " vertices, " + std::to_string(lines.faces) +
                                     " faces of " + std::to_string(lines.corners) + " corners)");
  Mesh mesh;
  const ParsedObj obj = parse_with_tinyobj(path, text, dir, estimate, mesh.warnings);
  mesh.material_files = obj.material_files;
  Corners corners = triangulate_faces(path, obj, lines);
  const std::array<bool, 2> complete = keep_complete_attributes(path, corners.keys, mesh.warnings);
  const Welded welded = weld(corners.keys, obj.attrib.vertices.size() / 3);
  fill_tensors(path, obj.attrib, corners.keys, welded, complete, mesh);
  pick_texture(path, dir, obj.materials, corners.material_of, mesh);
  mesh.validate("load_obj('" + path + "')");
  return mesh;
}

}  // namespace

Mesh load_obj(const std::string& path) {
  const fs::path dir = fs::path(path).parent_path();
  return load_obj_text(path, read_input_file(path, "load_obj('" + path + "')"), &dir);
}

Mesh load_obj_from_string(const std::string& text, const std::string& name) {
  return load_obj_text(name, text, nullptr);
}

// ---------------------------------------------------------------------------

namespace {

// Appends "<key> x y [z]\n" with the shortest decimal form that reads back as
// the same float.
void append_floats(std::string& out, const char* key, const float* x, int n) {
  char buf[128];
  char* p = buf;
  for (const char* k = key; *k; ++k) *p++ = *k;
  for (int i = 0; i < n; ++i) {
    *p++ = ' ';
    p = std::to_chars(p, buf + sizeof buf, x[i]).ptr;
  }
  *p++ = '\n';
  out.append(buf, p);
}

// Appends " i", " i/i", " i//i" or " i/i/i" for one face corner.
void append_corner(std::string& out, long i, bool uv, bool normal) {
  char buf[64];
  char* p = buf;
  *p++ = ' ';
  char num[24];
  char* num_end = std::to_chars(num, num + sizeof num, i).ptr;
  auto put = [&] { for (char* q = num; q < num_end; ++q) *p++ = *q; };
  put();
  if (uv || normal) {
    *p++ = '/';
    if (uv) put();
    if (normal) {
      *p++ = '/';
      put();
    }
  }
  out.append(buf, p);
}

}  // namespace

void save_obj(const std::string& path, const Mesh& mesh) {
  mesh.validate("save_obj('" + path + "')");
  OutputSet outputs;
  std::string out = "# written by gradraster\n";

  // Material file for the texture, next to the OBJ.
  if (!mesh.texture_path.empty()) {
    const fs::path obj(path);
    const fs::path mtl = fs::path(path).replace_extension(".mtl");
    std::error_code ec;
    fs::path tex = fs::proximate(mesh.texture_path, obj.parent_path().empty() ? fs::path(".") :
                                                                                 obj.parent_path(),
                                 ec);
    if (ec) tex = fs::absolute(mesh.texture_path);
    const std::string m = "# written by gradraster\nnewmtl material0\nKd 1 1 1\nmap_Kd " +
                          tex.generic_string() + "\n";
    outputs.stage(mtl.string(), m.data(), m.size());
    out += "mtllib " + mtl.filename().string() + "\nusemtl material0\n";
  }

  const std::int64_t n = mesh.num_vertices();
  out.reserve(static_cast<std::size_t>(n * 90 + mesh.num_triangles() * 40));
  const float* p = mesh.positions.data<float>();
  for (std::int64_t i = 0; i < n; ++i) append_floats(out, "v", p + 3 * i, 3);
  if (mesh.has_uvs()) {
    const float* t = mesh.uvs.data<float>();
    for (std::int64_t i = 0; i < n; ++i) append_floats(out, "vt", t + 2 * i, 2);
  }
  if (mesh.has_normals()) {
    const float* nn = mesh.normals.data<float>();
    for (std::int64_t i = 0; i < n; ++i) append_floats(out, "vn", nn + 3 * i, 3);
  }
  // Faces: one index per vertex, written as v, v/t, v//n or v/t/n.
  const std::int32_t* tri = mesh.triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < mesh.num_triangles(); ++f) {
    out += 'f';
    for (int c = 0; c < 3; ++c)
      append_corner(out, tri[3 * f + c] + 1L, mesh.has_uvs(), mesh.has_normals());
    out += '\n';
  }
  outputs.stage(path, out.data(), out.size());
  outputs.commit();
}

}  // namespace gr::raster
