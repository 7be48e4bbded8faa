// Texture decoding: PNG (RGB, RGBA, gray) and JPEG images encoded here, the
// size limits checked before decoding, and broken images.
#include "io/texture_io.h"

#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "io/png_io.h"
#include "test_images.h"

namespace vpr {
namespace {

constexpr size_t kManyPixels = size_t(1) << 26;

// A w x h image whose texel (x, y) is (17 x, 13 y, 255 - 7 (x + y)).
std::vector<uint8_t> pattern(int w, int h) {
  std::vector<uint8_t> rgb(3 * size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* t = &rgb[3 * size_t(y * w + x)];
      t[0] = uint8_t(17 * x);
      t[1] = uint8_t(13 * y);
      t[2] = uint8_t(255 - 7 * (x + y));
    }
  return rgb;
}

std::vector<uint8_t> png_of(int w, int h, uint32_t format, const std::vector<uint8_t>& pixels) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  image.width = png_uint_32(w);
  image.height = png_uint_32(h);
  image.format = format;
  png_alloc_size_t size = 0;
  EXPECT_TRUE(png_image_write_to_memory(&image, nullptr, &size, 0, pixels.data(), 0, nullptr));
  std::vector<uint8_t> out(size);
  EXPECT_TRUE(png_image_write_to_memory(&image, out.data(), &size, 0, pixels.data(), 0, nullptr));
  out.resize(size);
  return out;
}

StatusOr<RgbImage> decode(const std::vector<uint8_t>& bytes, size_t max_pixels = kManyPixels) {
  return decode_texture(bytes.data(), bytes.size(), 16384, max_pixels);
}

void expect_error(const StatusOr<RgbImage>& image, StatusCode code, const std::string& needle) {
  ASSERT_FALSE(image.ok()) << "expected an error containing '" << needle << "'";
  EXPECT_EQ(image.status().code(), code) << image.status().to_string();
  EXPECT_NE(image.status().message().find(needle), std::string::npos) << image.status().message();
}

TEST(TextureIo, PngRgbRgbaAndGrayDecodeToTheirTexels) {
  const int w = 5, h = 3;
  const std::vector<uint8_t> rgb = pattern(w, h);
  auto png = encode_rgb_png(w, h, rgb.data());
  ASSERT_TRUE(png.ok()) << png.status().to_string();
  auto image = decode(*png);
  ASSERT_TRUE(image.ok()) << image.status().to_string();
  ASSERT_EQ(image->width, w);
  ASSERT_EQ(image->height, h);
  for (size_t i = 0; i < size_t(w * h); ++i)
    for (size_t c = 0; c < 3; ++c) EXPECT_EQ(image->pixels[i][c], rgb[3 * i + c]) << "texel " << i;

  // Alpha is dropped, not multiplied in: a half-transparent texel keeps its color.
  std::vector<uint8_t> rgba;
  for (size_t i = 0; i < size_t(w * h); ++i) rgba.insert(rgba.end(), {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], 128});
  image = decode(png_of(w, h, PNG_FORMAT_RGBA, rgba));
  ASSERT_TRUE(image.ok()) << image.status().to_string();
  for (size_t i = 0; i < size_t(w * h); ++i)
    for (size_t c = 0; c < 3; ++c) EXPECT_EQ(image->pixels[i][c], rgb[3 * i + c]) << "texel " << i;

  const std::vector<uint8_t> gray = {0, 64, 200, 255};
  image = decode(png_of(2, 2, PNG_FORMAT_GRAY, gray));
  ASSERT_TRUE(image.ok()) << image.status().to_string();
  for (size_t i = 0; i < 4; ++i)
    for (size_t c = 0; c < 3; ++c) EXPECT_EQ(image->pixels[i][c], gray[i]);
}

// Quality 100 JPEG without chroma subsampling: within a few levels of the texels,
// baseline and progressive alike.
TEST(TextureIo, JpegDecodesNearItsTexels) {
  const int w = 16, h = 8;
  const std::vector<uint8_t> rgb = pattern(w, h);
  for (bool progressive : {false, true}) {
    auto image = decode(testing::encode_rgb_jpeg(w, h, rgb, progressive));
    ASSERT_TRUE(image.ok()) << image.status().to_string();
    ASSERT_EQ(image->width, w);
    ASSERT_EQ(image->height, h);
    int worst = 0;
    for (size_t i = 0; i < size_t(w * h); ++i)
      for (size_t c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(image->pixels[i][c]) - int(rgb[3 * i + c])));
    EXPECT_LE(worst, 4) << (progressive ? "progressive" : "baseline");
  }
}

// Sizes are refused from the header, before any pixel memory exists: an IHDR
// or SOF that declares 10^9 x 10^9 (PNG) or 60000 x 60000 (JPEG) in a few bytes.
TEST(TextureIo, DeclaredSizesBeyondTheLimitsFailBeforeDecoding) {
  auto png = encode_rgb_png(2, 2, pattern(2, 2).data());
  ASSERT_TRUE(png.ok());
  std::vector<uint8_t> huge = *png;
  const uint8_t billion[4] = {0x3b, 0x9a, 0xca, 0x00};  // 10^9, big-endian
  std::memcpy(&huge[16], billion, 4);
  std::memcpy(&huge[20], billion, 4);
  expect_error(decode(huge), StatusCode::kResourceExhausted,
               "PNG: the image is 1000000000 x 1000000000 pixels, the limit is 16384 per side");
  // Within the side limit but over the pixel budget.
  auto big = encode_rgb_png(64, 64, pattern(64, 64).data());
  ASSERT_TRUE(big.ok());
  expect_error(decode(*big, 4000), StatusCode::kResourceExhausted,
               "64 x 64 pixels, the limit is 16384 per side and 4000 pixels");

  std::vector<uint8_t> jpeg = testing::encode_rgb_jpeg(8, 8, pattern(8, 8), false);
  // The SOF0 marker: FF C0, length, precision, then height and width big-endian.
  size_t sof = 2;
  while (sof + 9 < jpeg.size() && !(jpeg[sof] == 0xff && jpeg[sof + 1] == 0xc0)) ++sof;
  ASSERT_LT(sof + 9, jpeg.size());
  for (size_t k : {sof + 5, sof + 7}) {
    jpeg[k] = 0xea;  // 60000
    jpeg[k + 1] = 0x60;
  }
  expect_error(decode(jpeg), StatusCode::kResourceExhausted, "JPEG: the image is 60000 x 60000 pixels");
}

TEST(TextureIo, BrokenImagesNameTheProblem) {
  const std::vector<uint8_t> rgb = pattern(32, 32);
  auto png = encode_rgb_png(32, 32, rgb.data());
  ASSERT_TRUE(png.ok());
  std::vector<uint8_t> cut(png->begin(), png->begin() + long(png->size() / 2));
  expect_error(decode(cut), StatusCode::kInvalidArgument, "PNG: cannot decode the image (libpng: ");
  std::vector<uint8_t> corrupt = *png;
  corrupt[30] ^= 0x40;  // IHDR's CRC no longer matches
  expect_error(decode(corrupt), StatusCode::kInvalidArgument, "PNG: cannot");

  std::vector<uint8_t> jpeg = testing::encode_rgb_jpeg(32, 32, rgb, false);
  std::vector<uint8_t> short_jpeg(jpeg.begin(), jpeg.begin() + long(jpeg.size() / 2));
  expect_error(decode(short_jpeg), StatusCode::kInvalidArgument, "JPEG: the image data is truncated");
  std::vector<uint8_t> header_only(jpeg.begin(), jpeg.begin() + 30);
  expect_error(decode(header_only), StatusCode::kInvalidArgument, "JPEG: cannot decode the image (libjpeg: ");

  const std::string webp = "RIFF\x10\x00\x00\x00WEBPVP8 ";
  expect_error(decode(std::vector<uint8_t>(webp.begin(), webp.end())), StatusCode::kInvalidArgument,
               "the image is neither PNG nor JPEG");
  expect_error(decode(std::vector<uint8_t>()), StatusCode::kInvalidArgument, "neither PNG nor JPEG (0 bytes");
}

}  // namespace
}  // namespace vpr
