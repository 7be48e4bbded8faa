// PNG through libpng's simplified API (png_image: errors come back in
// png_image::message, never by longjmp through our frames); JPEG through
// libjpeg's API, whose errors longjmp back to decode_jpeg's setjmp: only
// libjpeg's own C frames lie in between, and decode_jpeg keeps every object
// it owns alive across the jump.
#include "io/texture_io.h"

#include <png.h>

#include <array>
#include <csetjmp>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

// jpeglib.h needs size_t and FILE declared before it.
// clang-format off
#include <jpeglib.h>
#include <jerror.h>
// clang-format on

namespace vpr {

namespace {

// Progressive JPEGs of more scans than this take quadratic time for a few
// bytes each; libjpeg-turbo's TJFLAG_LIMITSCANS uses the same bound.
constexpr int kMaxJpegScans = 500;

Status check_size(const char* format, uint64_t width, uint64_t height, uint32_t max_side, size_t max_pixels) {
  if (width == 0 || height == 0)
    return invalid_argument(std::string(format) + ": the image is " + std::to_string(width) + " x " +
                            std::to_string(height) + " pixels");
  if (width > max_side || height > max_side || width * height > max_pixels)
    return resource_exhausted(std::string(format) + ": the image is " + std::to_string(width) + " x " +
                              std::to_string(height) + " pixels, the limit is " + std::to_string(max_side) +
                              " per side and " + std::to_string(max_pixels) + " pixels");
  return Status::Ok();
}

StatusOr<RgbImage> decode_png(const uint8_t* data, size_t size, uint32_t max_side, size_t max_pixels) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  auto failed = [&png](const char* when) {
    const std::string message = png.message;
    png_image_free(&png);
    return invalid_argument(std::string("PNG: cannot ") + when + " the image (libpng: " + message + ")");
  };
  // The size from IHDR first: libpng refuses sides beyond a million itself,
  // with a message that does not name our limit.
  if (size >= 24 && std::memcmp(data + 12, "IHDR", 4) == 0) {
    auto be32 = [](const uint8_t* p) {
      return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
    };
    VPR_RETURN_IF_ERROR(check_size("PNG", be32(data + 16), be32(data + 20), max_side, max_pixels));
  }
  if (!png_image_begin_read_from_memory(&png, data, size)) return failed("read the header of");
  if (Status s = check_size("PNG", png.width, png.height, max_side, max_pixels); !s.ok()) {
    png_image_free(&png);
    return s;
  }
  // 8-bit sRGB with straight (not premultiplied) alpha, which is dropped below.
  png.format = PNG_FORMAT_RGBA;
  const size_t pixels = size_t(png.width) * size_t(png.height);
  std::vector<uint8_t> rgba(4 * pixels);
  if (!png_image_finish_read(&png, nullptr, rgba.data(), 0, nullptr)) return failed("decode");
  png_image_free(&png);
  RgbImage image(int(png.width), int(png.height));
  for (size_t i = 0; i < pixels; ++i) image.pixels[i] = {rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]};
  return image;
}

static_assert(sizeof(std::array<uint8_t, 3>) == 3, "an RgbImage row is width x 3 bytes, as libjpeg writes it");

// Trivially destructible, so that a longjmp may leave it behind.
struct JpegState {
  jpeg_decompress_struct cinfo;
  jpeg_error_mgr error;
  jpeg_progress_mgr progress;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
  bool truncated;
};

JpegState* state_of(j_common_ptr cinfo) {
  return reinterpret_cast<JpegState*>(reinterpret_cast<char*>(cinfo) - offsetof(JpegState, cinfo));
}

[[noreturn]] void on_jpeg_error(j_common_ptr cinfo) {
  JpegState* state = state_of(cinfo);
  (*cinfo->err->format_message)(cinfo, state->message);
  std::longjmp(state->jump, 1);
}

// Warnings (msg_level -1) are not printed; a truncated stream, which libjpeg
// would pad with gray, fails after the decode.
void on_jpeg_message(j_common_ptr cinfo, int msg_level) {
  if (msg_level < 0 && cinfo->err->msg_code == JWRN_JPEG_EOF) state_of(cinfo)->truncated = true;
}

void on_jpeg_progress(j_common_ptr cinfo) {
  const auto* d = reinterpret_cast<j_decompress_ptr>(cinfo);
  if (d->progressive_mode && d->input_scan_number > kMaxJpegScans) {
    JpegState* state = state_of(cinfo);
    std::snprintf(state->message, sizeof state->message, "a progressive JPEG of more than %d scans", kMaxJpegScans);
    std::longjmp(state->jump, 1);
  }
}

StatusOr<RgbImage> decode_jpeg(const uint8_t* data, size_t size, uint32_t max_side, size_t max_pixels) {
  JpegState state;
  std::memset(&state, 0, sizeof state);
  RgbImage image;
  Status refused;
  jpeg_decompress_struct* cinfo = &state.cinfo;
  cinfo->err = jpeg_std_error(&state.error);
  state.error.error_exit = on_jpeg_error;
  state.error.emit_message = on_jpeg_message;
  state.progress.progress_monitor = on_jpeg_progress;
  if (setjmp(state.jump)) {
    jpeg_destroy_decompress(cinfo);
    return invalid_argument(std::string("JPEG: cannot decode the image (libjpeg: ") + state.message + ")");
  }
  jpeg_create_decompress(cinfo);
  cinfo->progress = &state.progress;
  jpeg_mem_src(cinfo, data, static_cast<unsigned long>(size));
  jpeg_read_header(cinfo, TRUE);
  refused = check_size("JPEG", cinfo->image_width, cinfo->image_height, max_side, max_pixels);
  if (!refused.ok()) {
    jpeg_destroy_decompress(cinfo);
    return refused;
  }
  // A progressive image keeps its coefficients (2 bytes each, up to 3 per
  // pixel before subsampling) until the end: a bound libjpeg enforces.
  cinfo->mem->max_memory_to_use = long(8 * size_t(cinfo->image_width) * cinfo->image_height + (64 << 20));
  cinfo->out_color_space = JCS_RGB;
  jpeg_start_decompress(cinfo);
  if (cinfo->output_components != 3) {
    std::snprintf(state.message, sizeof state.message, "%d output components", cinfo->output_components);
    std::longjmp(state.jump, 1);
  }
  image = RgbImage(int(cinfo->output_width), int(cinfo->output_height));
  while (cinfo->output_scanline < cinfo->output_height) {
    JSAMPROW row = image.pixels[size_t(cinfo->output_scanline) * size_t(image.width)].data();
    jpeg_read_scanlines(cinfo, &row, 1);
  }
  jpeg_finish_decompress(cinfo);
  jpeg_destroy_decompress(cinfo);
  if (state.truncated) return invalid_argument("JPEG: the image data is truncated");
  return image;
}

}  // namespace

StatusOr<RgbImage> decode_texture(const uint8_t* data, size_t size, uint32_t max_side, size_t max_pixels) {
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static const uint8_t kJpeg[3] = {0xff, 0xd8, 0xff};
  if (size >= 8 && std::memcmp(data, kPng, 8) == 0) return decode_png(data, size, max_side, max_pixels);
  if (size >= 3 && std::memcmp(data, kJpeg, 3) == 0) return decode_jpeg(data, size, max_side, max_pixels);
  return invalid_argument("the image is neither PNG nor JPEG (" + std::to_string(size) +
                          " bytes without either signature; WebP, KTX2 and others are not read)");
}

}  // namespace vpr
