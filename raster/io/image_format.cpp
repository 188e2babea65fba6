// Image formats by their first bytes (see image_format.h). The accepted
// formats are checked first; the refused ones are named so that the message
// says what the file is instead of "corrupt".
#include "raster/io/image_format.h"

#include <cstdint>

#include "autodiff/base/error.h"
#include "raster/io/files.h"

namespace gr::raster {
namespace {

bool starts_with(std::string_view bytes, std::string_view prefix) {
  return bytes.substr(0, prefix.size()) == prefix;
}

std::uint8_t byte_at(std::string_view bytes, std::size_t i) { return static_cast<std::uint8_t>(bytes[i]); }

// TGA has no signature: its 18-byte header must describe a TGA image. Colour
// map type 0 goes with true-colour or grey images (types 2, 3; RLE 10, 11),
// type 1 with colour-mapped ones (1, 9) whose pixels are 8- or 16-bit indices.
bool has_tga_header(std::string_view bytes) {
  if (bytes.size() < 18) return false;
  const int colour_map = byte_at(bytes, 1), type = byte_at(bytes, 2);
  const int width = byte_at(bytes, 12) | byte_at(bytes, 13) << 8;
  const int height = byte_at(bytes, 14) | byte_at(bytes, 15) << 8;
  const int bits = byte_at(bytes, 16);
  const auto is_pixel_size = [](int b) { return b == 8 || b == 15 || b == 16 || b == 24 || b == 32; };
  if (width < 1 || height < 1) return false;
  if (colour_map == 0) return (type == 2 || type == 3 || type == 10 || type == 11) && is_pixel_size(bits);
  if (colour_map == 1)
    return (type == 1 || type == 9) && is_pixel_size(byte_at(bytes, 7)) && (bits == 8 || bits == 16);
  return false;
}

// Formats stb_image (or a user) might hand us, recognised by signature only to
// name them; none of them is decoded. Empty if the bytes match none.
std::string refused_format(std::string_view bytes) {
  if (starts_with(bytes, "#?")) return "a Radiance HDR image";
  if (starts_with(bytes, "GIF87a") || starts_with(bytes, "GIF89a")) return "a GIF image";
  if (bytes.size() >= 3 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '7' &&
      (bytes[2] == '\n' || bytes[2] == '\r' || bytes[2] == ' ' || bytes[2] == '\t'))
    return "a PNM (Netpbm) image";
  if (starts_with(bytes, "8BPS")) return "a Photoshop PSD image";
  if (starts_with(bytes, "\x53\x80\xf6\x34")) return "a Softimage PIC image";
  if (starts_with(bytes, std::string_view("II*\0", 4)) || starts_with(bytes, std::string_view("MM\0*", 4)))
    return "a TIFF image";
  if (bytes.size() >= 12 && starts_with(bytes, "RIFF") && bytes.substr(8, 4) == "WEBP") return "a WebP image";
  if (starts_with(bytes, "\x76\x2f\x31\x01")) return "an OpenEXR image";
  if (starts_with(bytes, "qoif")) return "a QOI image";
  return {};
}

}  // namespace

const char* image_format_name(ImageFormat format) {
  switch (format) {
    case ImageFormat::Png: return "PNG";
    case ImageFormat::Jpeg: return "JPEG";
    case ImageFormat::Bmp: return "BMP";
    case ImageFormat::Tga: return "TGA";
  }
  return "?";
}

ImageFormat identify_image_format(std::string_view bytes, const std::string& what) {
  if (starts_with(bytes, "\x89PNG\r\n\x1a\n")) return ImageFormat::Png;
  if (starts_with(bytes, "\xff\xd8\xff")) return ImageFormat::Jpeg;
  if (starts_with(bytes, "BM")) return ImageFormat::Bmp;
  const std::string refused = refused_format(bytes);
  if (!refused.empty())
    throw IOError(what + ": it is " + refused + "; only PNG, JPEG, BMP and TGA images are read");
  if (has_tga_header(bytes)) return ImageFormat::Tga;
  if (bytes.empty()) throw IOError(what + ": the file is empty; expected a PNG, JPEG, BMP or TGA image");
  throw IOError(what + ": not a PNG, JPEG, BMP or TGA image (it starts with " +
                quote_for_message(std::string(bytes.substr(0, 8))) + ")");
}

}  // namespace gr::raster
