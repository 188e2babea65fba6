// A check of a JPEG file's marker segments before stb_image reads them.
//
// stb_image 2.27 (Debian 12's) builds a Huffman table from a DHT segment
// without checking that its 16 code counts add up to at most 256, and writes
// past the table when they do (found by fuzz_image; later stb versions check
// it). So read_image walks the segments first, also those between the scans
// of a progressive JPEG, and refuses such a table.
#pragma once

#include <string>
#include <string_view>

namespace gr::raster {

// Throws IOError starting with `what` for a JPEG whose Huffman tables (DHT
// segments) define more than 256 codes. `bytes` is a whole file that starts
// with the JPEG signature. A file that ends early is left to the decoder.
void check_jpeg_huffman_tables(std::string_view bytes, const std::string& what);

}  // namespace gr::raster
