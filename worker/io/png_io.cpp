// PNG output through libpng's simplified API (png_image), which reports errors
// in png_image::message instead of longjmp-ing through our frames.
#include "io/png_io.h"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

namespace vpr {

namespace {

Status write_png_pixels(const std::string& path, int width, int height, uint32_t format, const uint8_t* pixels,
                        size_t pixel_bytes) {
  const int channels = PNG_IMAGE_SAMPLE_CHANNELS(format);
  if (width <= 0 || height <= 0)
    return invalid_argument("PNG '" + path + "': the image is " + std::to_string(width) + " x " +
                            std::to_string(height) + " pixels, both sides must be positive");
  const size_t expected = size_t(width) * size_t(height) * size_t(channels);
  if (pixels == nullptr || pixel_bytes != expected)
    return invalid_argument("PNG '" + path + "': " + std::to_string(pixel_bytes) + " bytes of pixels for a " +
                            std::to_string(width) + " x " + std::to_string(height) + " image that needs " +
                            std::to_string(expected));
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    const int err = errno;
    const std::string message = "cannot write '" + path + "': " + std::strerror(err);
    return (err == ENOENT || err == ENOTDIR) ? not_found(message) : internal_error(message);
  }
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(width);
  image.height = png_uint_32(height);
  image.format = format;
  const int ok = png_image_write_to_stdio(&image, f, 0, pixels, 0, nullptr);
  const std::string libpng_message = image.message;
  png_image_free(&image);
  const int close_result = std::fclose(f);
  if (!ok) return internal_error("cannot write PNG '" + path + "': libpng: " + libpng_message);
  if (close_result != 0) return internal_error("cannot write PNG '" + path + "': " + std::strerror(errno));
  return Status::Ok();
}

}  // namespace

Status write_png(const std::string& path, const GrayImage& image) {
  return write_png_pixels(path, image.width, image.height, PNG_FORMAT_GRAY, image.pixels.data(), image.pixels.size());
}

Status write_mask_png(const std::string& path, const Mask& mask) {
  std::vector<uint8_t> gray(mask.pixels.size());
  for (size_t i = 0; i < gray.size(); ++i) gray[i] = mask.pixels[i] ? 255 : 0;
  return write_png_pixels(path, mask.width, mask.height, PNG_FORMAT_GRAY, gray.data(), gray.size());
}

Status write_rgb_png(const std::string& path, int width, int height, const uint8_t* rgb) {
  const size_t bytes = (width > 0 && height > 0) ? size_t(width) * size_t(height) * 3 : 0;
  return write_png_pixels(path, width, height, PNG_FORMAT_RGB, rgb, bytes);
}

}  // namespace vpr
