// PNG encoding (libpng, speed-tuned) and decoding (libpng's simplified API).
#include <csetjmp>
#include <cstring>
#include <fstream>

#include <fmt/format.h>
#include <png.h>

#include "scaratwin/sim/camera.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {
namespace {

Error png_error_value(std::string message) {
  return Error{static_cast<int>(SimError::kRender), std::move(message)};
}

struct Sink {
  std::vector<std::uint8_t>* out;
};

extern "C" void write_to_vector(png_structp png, png_bytep data, png_size_t n) {
  auto* sink = static_cast<Sink*>(png_get_io_ptr(png));
  sink->out->insert(sink->out->end(), data, data + n);
}
extern "C" void flush_nothing(png_structp) {}

// libpng reports errors by longjmp; everything with a destructor lives in the caller.
bool encode_rows(const Image& image, int level, std::vector<std::uint8_t>& out,
                 std::vector<png_bytep>& rows, char* message) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  Sink sink{&out};
  if (setjmp(png_jmpbuf(png))) {
    std::snprintf(message, 128, "libpng failed while encoding");
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &sink, write_to_vector, flush_nothing);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width_px),
               static_cast<png_uint_32>(image.height_px), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, level);
  // the "up" filter suits rendered scenes (large flat areas) and is cheap
  png_set_filter(png, PNG_FILTER_TYPE_BASE, level <= 1 ? PNG_FILTER_UP : PNG_ALL_FILTERS);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_png(const Image& image, int level) {
  if (image.width_px < 1 || image.height_px < 1 ||
      image.rgb.size() != static_cast<std::size_t>(image.width_px) * image.height_px * 3) {
    return png_error_value(fmt::format("image {}x{} with {} bytes: needs width*height*3 bytes",
                                       image.width_px, image.height_px, image.rgb.size()));
  }
  if (level < 0 || level > 9) {
    return png_error_value(fmt::format("PNG level {}: must be 0..9", level));
  }
  std::vector<std::uint8_t> out;
  out.reserve(image.rgb.size() / 2);
  std::vector<png_bytep> rows(image.height_px);
  for (int r = 0; r < image.height_px; ++r) {
    rows[r] =
        const_cast<png_bytep>(image.rgb.data() + static_cast<std::size_t>(r) * image.width_px * 3);
  }
  char message[128] = "libpng could not start";
  if (!encode_rows(image, level, out, rows, message)) return png_error_value(message);
  return out;
}

Status save_png(const Image& image, const std::string& path, int level) {
  auto png = encode_png(image, level);
  if (!png) return png.error();
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(png->data()), static_cast<std::streamsize>(png->size()));
  f.close();
  if (!f) return png_error_value(fmt::format("cannot write '{}'", path));
  return Ok{};
}

}  // namespace scaratwin::sim
