// The scatter loops' case of vertex_ranges_test and range_lists_test:
// pseudo-random "faces" (three corners each) and a value per face whose
// rounding, summed into a vertex, depends on the order of the additions.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace vpr::testing {

// 3 nf corners among nv vertices, the same on every machine.
inline std::vector<uint32_t> random_corners(size_t nv, size_t nf) {
  std::vector<uint32_t> corner(3 * nf);
  uint64_t state = 12345;
  for (uint32_t& c : corner) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    c = uint32_t((state >> 33) % nv);
  }
  return corner;
}

inline double order_sensitive_value(size_t f) {
  return std::sin(double(f)) * 1e3 + 1.0 / double(f + 1);
}

}  // namespace vpr::testing
