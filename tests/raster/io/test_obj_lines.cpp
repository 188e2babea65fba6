// raster/io/obj_lines.h: the OBJ loader's own pass over the text (counts for the
// memory estimate, and the lines tinyobjloader is given).
#include <catch2/catch.hpp>

#include <string>

#include "autodiff/base/error.h"
#include "raster/io/obj_lines.h"

using namespace gr::raster;

TEST_CASE("check_obj_lines counts vertices, faces and corners - a quad is two triangles", "[raster][io][obj]") {
  const std::string text =
      "# a quad and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
      "usemtl red\nf 1 2 3 4\nf 1/1/1 2/1/1 3/1/1\n";
  const ObjLineCounts c = check_obj_lines("quad.obj", text);
  CHECK(c.bytes == text.size());
  CHECK(c.lines == 10);
  CHECK(c.v == 4);
  CHECK(c.vt == 1);
  CHECK(c.vn == 1);
  CHECK(c.faces == 2);
  CHECK(c.corners == 7);
  CHECK(c.triangles() == 3);
  CHECK(c.usemtl == 1);
  CHECK(c.parser_bytes == parser_text(text).size());
}

TEST_CASE("parser_text keeps v, vt, vn, f without comments and usemtl, mtllib as they are - other lines stay empty",
          "[raster][io][obj]") {
  const std::string text = "o name\nv 0 0 0 # corner\nt a 8192/8192/8192\nmtllib x.mtl\nf 1 2 3#4 5\ng group\n";
  CHECK(parser_text(text) == "\nv 0 0 0 \n\nmtllib x.mtl\nf 1 2 3\n\n");
}

TEST_CASE("check_obj_lines names the file and the line of the first problem", "[raster][io][obj][bad_input]") {
  CHECK_THROWS_WITH(check_obj_lines("bad.obj", "v 0 0 0\nv 1 0\n"),
                    Catch::Contains("bad.obj") && Catch::Contains("line 2"));
  CHECK_THROWS_WITH(check_obj_lines("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
                    Catch::Contains("line 4") && Catch::Contains("vertex 4"));
}
