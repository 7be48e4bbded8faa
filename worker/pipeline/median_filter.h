// Median pre-filter (Section III-A): removes shading noise before the
// inner-feature filter. Integer-exact, so the GPU twin gives identical pixels.
#pragma once

#include "exec_context.h"
#include "image.h"
#include "status.h"

namespace vpr::cpu {

// size x size window (odd); pixels outside the image are clamped to the edge.
Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& ctx);

}  // namespace vpr::cpu
