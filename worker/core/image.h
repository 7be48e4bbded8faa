// Row-major images: single-channel, and 8-bit RGB for textures. Row 0 is the
// top of the picture (glReadPixels output is flipped once, in the renderer).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vpr {

template <class T>
struct Image {
  int width = 0;
  int height = 0;
  std::vector<T> pixels;  // width * height, row-major

  Image() = default;
  Image(int w, int h, T fill = T{}) : width(w), height(h), pixels(size_t(w) * size_t(h), fill) {}
  T& at(int x, int y) { return pixels[size_t(y) * width + x]; }
  const T& at(int x, int y) const { return pixels[size_t(y) * width + x]; }
  bool in_bounds(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
};

using GrayImage = Image<uint8_t>;  // 0..255 shaded intensity
using Mask = Image<uint8_t>;       // 0 or 1
using FloatImage = Image<float>;
using RgbImage = Image<std::array<uint8_t, 3>>;  // 8-bit sRGB color (textures)

}  // namespace vpr
