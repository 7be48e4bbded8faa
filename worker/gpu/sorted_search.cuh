// Small helpers of the twins that sort on the device and then look up each
// vertex's run in the sorted array (mesh_edges.cu, mean_curvature.cu).
#pragma once

#include <cstddef>
#include <cstdint>

namespace vpr::cuda {

// The first of the n ascending values that is v or more (n when none is).
__device__ inline uint32_t first_at_least(const uint32_t* sorted, uint32_t n, uint32_t v) {
  uint32_t lo = 0, hi = n;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (sorted[mid] < v)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

// Radix-sort bits that hold every value 0 .. n.
inline int bits_for(size_t n) {
  int bits = 1;
  while (bits < 32 && (size_t(1) << bits) <= n) ++bits;
  return bits;
}

}  // namespace vpr::cuda
