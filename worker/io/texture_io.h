// Texture images for base-color textures: PNG (libpng's simplified API) and
// JPEG (libjpeg-turbo), decoded to 8-bit sRGB RGB.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/image.h"
#include "core/status.h"

namespace vpr {

// Told apart by their signatures, not by a declared type. Alpha is dropped
// (glTF's base color keeps RGB and alpha apart), gray is expanded, 16-bit
// PNGs are reduced and PNGs with a gamma of their own are converted to sRGB.
// The size in the image's header is checked before any pixel is decoded:
// each side at most max_side and width x height at most max_pixels, else
// RESOURCE_EXHAUSTED naming the size and the limit. Anything else that cannot
// be read (another format, a truncated or corrupt image, CMYK JPEG, a
// progressive JPEG of more than 500 scans) is INVALID_ARGUMENT with the
// decoder's reason. Never reads outside [data, data + size).
StatusOr<RgbImage> decode_texture(const uint8_t* data, size_t size, uint32_t max_side, size_t max_pixels);

}  // namespace vpr
