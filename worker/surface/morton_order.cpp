#include "surface/morton_order.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <utility>

namespace vpr {
namespace {

constexpr double kCells = 2097151.0;  // 2^21 - 1: three axes' bits fill 63 of a 64-bit code

// The 21 low bits of v, each moved to every third bit.
uint64_t spread_bits(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

uint64_t grid_cell(double c, double lo, double extent) {
  const double t = (c - lo) / extent * kCells;
  return uint64_t(std::clamp(
      t, 0.0,
      kCells));  // positions are finite (validate_mesh); the clamp keeps rounding at the box's faces in the grid
}

}  // namespace

std::vector<uint32_t> morton_order(const std::vector<Vec3d>& x, const std::vector<uint32_t>& elements, Vec3d lo,
                                   double extent) {
  if (!(extent > 0)) extent = 1;
  std::vector<std::pair<uint64_t, uint32_t>> keyed(elements.size());
  tbb::parallel_for(size_t(0), elements.size(), [&](size_t i) {
    const Vec3d& p = x[elements[i]];
    keyed[i] = {spread_bits(grid_cell(p.x, lo.x, extent)) | spread_bits(grid_cell(p.y, lo.y, extent)) << 1 |
                    spread_bits(grid_cell(p.z, lo.z, extent)) << 2,
                elements[i]};
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());  // (code, index): distinct keys, one order
  std::vector<uint32_t> out(keyed.size());
  for (size_t i = 0; i < keyed.size(); ++i) out[i] = keyed[i].second;
  return out;
}

}  // namespace vpr
