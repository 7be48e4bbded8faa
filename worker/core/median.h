// Medians for normalizing per-vertex quantities (curvature, importance).
#pragma once

#include <algorithm>
#include <vector>

namespace vpr {

// The median of v (the upper one for an even count); 0 for an empty v.
inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The typical size of a non-negative quantity: its median or, where that is
// 0 (a mostly flat, CAD-like surface), the median of its positive values;
// 0 when none is positive.
inline double typical_positive_value(const std::vector<double>& v) {
  const double median = median_of(v);
  if (median > 0) return median;
  std::vector<double> positive;
  for (double x : v)
    if (x > 0) positive.push_back(x);
  return median_of(positive);
}

}  // namespace vpr
