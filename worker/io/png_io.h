// PNG output for debug images and tests (libpng); textures are read by
// texture_io.h.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/status.h"

namespace vpr {

Status write_png(const std::string& path, const GrayImage& image);
// Masks are written as 0 -> black, nonzero -> white.
Status write_mask_png(const std::string& path, const Mask& mask);
// 8-bit RGB, width * height * 3 bytes, row 0 at the top.
Status write_rgb_png(const std::string& path, int width, int height, const uint8_t* rgb);
// The same image as PNG bytes in memory.
StatusOr<std::vector<uint8_t>> encode_rgb_png(int width, int height, const uint8_t* rgb);

}  // namespace vpr
