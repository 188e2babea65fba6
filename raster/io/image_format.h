// Which image formats read_image accepts, told by a file's first bytes.
//
// stb_image decodes more formats than gradraster documents (Radiance HDR, GIF,
// PNM, PSD, Softimage PIC), and its HDR decoder loops forever on a truncated
// file (issue 30). So read_image names the format itself, from the bytes,
// before any decoder runs, and accepts only PNG, JPEG, BMP and TGA.
#pragma once

#include <string>
#include <string_view>

namespace gr::raster {

enum class ImageFormat { Png, Jpeg, Bmp, Tga };

// "PNG", "JPEG", "BMP" or "TGA".
const char* image_format_name(ImageFormat format);

// The format of the file whose whole content is `bytes`: PNG, JPEG and BMP by
// their signatures; TGA, which has none, by a header whose colour-map type,
// image type, sides and bits per pixel are those of a TGA file. Anything else
// throws IOError starting with `what`: a format recognised by its signature
// is named ("it is a Radiance HDR image; only PNG, JPEG, BMP and TGA are
// read"), other bytes are quoted by their first 8.
ImageFormat identify_image_format(std::string_view bytes, const std::string& what);

}  // namespace gr::raster
