// Bounding spheres of triangles, to prune nearest-triangle searches: a
// triangle whose sphere lies farther from the query than the best distance
// found so far cannot hold the nearest point, so its closest point need not
// be computed.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>

namespace vpr {

// A triangle's bounding sphere: centre x, y, z (the centroid, in float) and
// radius. The radius is measured from the stored centre and rounded up by
// 1e-5 of itself, so that a search which skips a triangle only when its
// sphere is farther than the best distance (with a relative margin of 1e-6,
// sphere_gap2 below) picks the point a full search picks, bit for bit.
inline std::array<float, 4> bounding_sphere(const Eigen::Vector3d (&corner)[3]) {
  const Eigen::Vector3d mid = (corner[0] + corner[1] + corner[2]) / 3;
  const Eigen::Vector3d centre(float(mid.x()), float(mid.y()), float(mid.z()));
  double radius = 0;
  for (const Eigen::Vector3d& c : corner) radius = std::max(radius, (c - centre).norm());
  return {float(centre.x()), float(centre.y()), float(centre.z()), float(radius * (1 + 1e-5))};
}

// Squared distance from x to the sphere s (0 inside it): a lower bound of
// the squared distance from x to any point of the triangle.
inline double sphere_gap2(const Eigen::Vector3d& x, const std::array<float, 4>& s) {
  const double dx = x.x() - s[0], dy = x.y() - s[1], dz = x.z() - s[2];
  const double gap = std::sqrt(dx * dx + dy * dy + dz * dz) - s[3];
  return gap > 0 ? gap * gap : 0.0;
}

}  // namespace vpr
