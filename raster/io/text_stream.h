// An std::istream over text held elsewhere, for tinyobjloader, which reads
// from streams. std::istringstream would copy the text: one more byte per
// byte of a large OBJ or MTL file.
#pragma once

#include <istream>
#include <streambuf>
#include <string_view>

namespace gr::raster {

class TextStream : private std::streambuf, public std::istream {
 public:
  // `text` must outlive the stream.
  explicit TextStream(std::string_view text) : std::istream(static_cast<std::streambuf*>(this)) {
    char* p = const_cast<char*>(text.data());  // only ever read: the get area is not written
    setg(p, p, p + text.size());
  }
};

}  // namespace gr::raster
