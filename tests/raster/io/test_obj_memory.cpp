// raster/io/obj_memory.h: upper bounds of what loading an OBJ and its MTL files
// holds. The bounds against measured peaks are tested through load_obj
// (test_mesh_io.cpp); here, that every count costs memory.
#include <catch2/catch.hpp>

#include "raster/io/obj_lines.h"
#include "raster/io/obj_memory.h"

using namespace gr::raster;

TEST_CASE("obj_load_bytes covers the text and grows with every count it is given", "[raster][io][obj][memory]") {
  ObjLineCounts base;
  base.bytes = base.parser_bytes = 1000;
  base.lines = 10;
  base.v = base.vt = base.vn = 3;
  base.faces = 1;
  base.corners = 3;
  const std::size_t at_base = obj_load_bytes(base, 8);
  CHECK(at_base >= base.bytes + base.parser_bytes);
  for (std::size_t ObjLineCounts::*count : {&ObjLineCounts::v, &ObjLineCounts::vt, &ObjLineCounts::vn,
                                            &ObjLineCounts::corners, &ObjLineCounts::usemtl}) {
    ObjLineCounts more = base;
    more.*count += 1000;
    CHECK(obj_load_bytes(more, 8) > at_base);
  }
  // Many-corner faces: each added corner is a triangle more.
  ObjLineCounts polygon = base;
  polygon.corners = 255;
  CHECK(obj_load_bytes(polygon, 8) > at_base + 252 * 3 * sizeof(int));
}

TEST_CASE("an MTL file holds more with more materials, and parsing it costs at least its text",
          "[raster][io][obj][mtl][memory]") {
  MtlLineCounts one;
  one.bytes = one.parser_bytes = 100;
  one.materials = 1;
  one.longest_kept_line = 20;
  MtlLineCounts many = one;
  many.materials = 1000;
  CHECK(mtl_held_bytes(many) > mtl_held_bytes(one));
  CHECK(mtl_parse_bytes(one) >= one.bytes);
}
