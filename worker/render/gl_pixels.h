// One snapshot pixel from the rows glReadPixels leaves (bottom row first):
// shared by the host's read-back (snapshot.cpp) and the GPU's hand-over
// (device_snapshots.cu), so a snapshot is the same bits whichever way its
// pixels left GL.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/vec3.h"

namespace vpr::gl {

// rgba: width x height RGBA8, depth: width x height floats, both as GL reads
// them (row 0 at the bottom). Writes pixel (x, y) of the snapshot (row 0 at
// the top): where nothing was drawn (depth not below 1) gray 0, depth 1 and
// coverage 0; elsewhere the red channel (the shading is gray), the depth and 1.
VPR_HD inline void snapshot_pixel(const uint8_t* rgba, const float* depth, int width, int height, int x, int y,
                                  uint8_t* gray_out, float* depth_out, uint8_t* coverage_out) {
  const size_t src = size_t(height - 1 - y) * size_t(width) + size_t(x);
  const size_t dst = size_t(y) * size_t(width) + size_t(x);
  const float z = depth[src];
  const bool drawn = z < 1.0f;  // false for NaN too
  depth_out[dst] = drawn ? z : 1.0f;
  coverage_out[dst] = drawn ? 1 : 0;
  gray_out[dst] = drawn ? rgba[4 * src] : 0;
}

}  // namespace vpr::gl
