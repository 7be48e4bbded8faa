#include "core/color.h"

#include <array>
#include <cmath>

namespace vpr {

namespace {

double decode(double s) {
  return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
}

const std::array<float, 256>& decode_table() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[size_t(i)] = float(decode(i / 255.0));
    return t;
  }();
  return table;
}

}  // namespace

float srgb_to_linear(uint8_t value) {
  return decode_table()[value];
}

uint8_t srgb_from_linear(float linear) {
  if (!(linear > 0)) return 0;  // NaN too
  if (linear >= 1) return 255;
  const double l = linear;
  const double s = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055;
  return uint8_t(std::lround(s * 255));
}

}  // namespace vpr
