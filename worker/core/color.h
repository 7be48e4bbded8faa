// The sRGB transfer function (IEC 61966-2-1), between the 8-bit sRGB values
// files store (PLY, OBJ, Draco colors, PNG and JPEG texels) and linear light,
// where colors are blended (glTF 2.0, 3.9.2: COLOR_0 is linear; sRGB
// textures are decoded before they are filtered).
#pragma once

#include <cstdint>

namespace vpr {

// 0..255 -> [0, 1], exact to a float (a table).
float srgb_to_linear(uint8_t value);
// [0, 1] -> 0..255, rounded to the nearest; values outside are clamped, NaN
// gives 0. srgb_from_linear(srgb_to_linear(b)) == b for every byte.
uint8_t srgb_from_linear(float linear);

}  // namespace vpr
