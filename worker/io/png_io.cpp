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

// The image's description for libpng, after checking the pixels fit it.
// name: for messages (a path, or "in memory").
Status describe(const std::string& name, int width, int height, uint32_t format, const uint8_t* pixels,
                size_t pixel_bytes, png_image* image) {
  const int channels = PNG_IMAGE_SAMPLE_CHANNELS(format);
  if (width <= 0 || height <= 0)
    return invalid_argument("PNG '" + name + "': the image is " + std::to_string(width) + " x " +
                            std::to_string(height) + " pixels, both sides must be positive");
  const size_t expected = size_t(width) * size_t(height) * size_t(channels);
  if (pixels == nullptr || pixel_bytes != expected)
    return invalid_argument("PNG '" + name + "': " + std::to_string(pixel_bytes) + " bytes of pixels for a " +
                            std::to_string(width) + " x " + std::to_string(height) + " image that needs " +
                            std::to_string(expected));
  std::memset(image, 0, sizeof *image);
  image->version = PNG_IMAGE_VERSION;
  image->width = png_uint_32(width);
  image->height = png_uint_32(height);
  image->format = format;
  return Status::Ok();
}

Status write_png_pixels(const std::string& path, int width, int height, uint32_t format, const uint8_t* pixels,
                        size_t pixel_bytes) {
  png_image image;
  VPR_RETURN_IF_ERROR(describe(path, width, height, format, pixels, pixel_bytes, &image));
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    const int err = errno;
    const std::string message = "cannot write '" + path + "': " + std::strerror(err);
    return (err == ENOENT || err == ENOTDIR) ? not_found(message) : internal_error(message);
  }
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

namespace {

size_t rgb_bytes(int width, int height) {
  return (width > 0 && height > 0) ? size_t(width) * size_t(height) * 3 : 0;
}

}  // namespace

Status write_rgb_png(const std::string& path, int width, int height, const uint8_t* rgb) {
  return write_png_pixels(path, width, height, PNG_FORMAT_RGB, rgb, rgb_bytes(width, height));
}

StatusOr<std::vector<uint8_t>> encode_rgb_png(int width, int height, const uint8_t* rgb) {
  png_image image;
  VPR_RETURN_IF_ERROR(describe("in memory", width, height, PNG_FORMAT_RGB, rgb, rgb_bytes(width, height), &image));
  png_alloc_size_t size = 0;
  std::vector<uint8_t> out;
  // The first call measures, the second writes.
  int ok = png_image_write_to_memory(&image, nullptr, &size, 0, rgb, 0, nullptr);
  if (ok) {
    out.resize(size);
    ok = png_image_write_to_memory(&image, out.data(), &size, 0, rgb, 0, nullptr);
    out.resize(size);
  }
  const std::string libpng_message = image.message;
  png_image_free(&image);
  if (!ok) return internal_error("cannot encode a PNG: libpng: " + libpng_message);
  return out;
}

}  // namespace vpr
