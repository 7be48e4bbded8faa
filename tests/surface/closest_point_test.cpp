// The closest-point tree against brute force over every face: distances,
// faces and barycentric coordinates.
#include "surface/closest_point.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/rng.h"
#include "test_meshes.h"

namespace vpr {
namespace {

// Closest point of triangle abc to p by brute force: the interior projection
// when it falls inside, else the nearest point of the three edges.
double squared_distance_to_triangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  auto on_segment = [&](const Vec3d& x, const Vec3d& y) {
    const Vec3d d = y - x;
    const double t = std::clamp(dot(p - x, d) / dot(d, d), 0.0, 1.0);
    return norm2(p - (x + d * t));
  };
  const Vec3d n = cross(b - a, c - a);
  const Vec3d q = p - n * (dot(p - a, n) / dot(n, n));
  const bool inside =
      dot(cross(b - a, q - a), n) >= 0 && dot(cross(c - b, q - b), n) >= 0 && dot(cross(a - c, q - c), n) >= 0;
  if (inside) return norm2(p - q);
  return std::min({on_segment(a, b), on_segment(b, c), on_segment(c, a)});
}

TEST(ClosestPointTree, MatchesBruteForceAndItsBarycentricsRebuildThePoint) {
  const Mesh sphere = testing::icosphere(3);
  const ClosestPointTree tree(sphere);
  ASSERT_FALSE(tree.empty());
  const float* x = sphere.positions.data();
  for (uint64_t i = 0; i < 300; ++i) {
    const Philox4 r = random4(11, i, 0);
    // Points inside, near and outside the unit sphere.
    const Vec3d p = {2.4 * uniform01(r.v[0]) - 1.2, 2.4 * uniform01(r.v[1]) - 1.2, 2.4 * uniform01(r.v[2]) - 1.2};
    double best = std::numeric_limits<double>::infinity();
    for (size_t f = 0; f < sphere.face_count(); ++f)
      best = std::min(
          best, squared_distance_to_triangle(p, load3d(x, sphere.indices[3 * f]), load3d(x, sphere.indices[3 * f + 1]),
                                             load3d(x, sphere.indices[3 * f + 2])));
    const ClosestPointTree::Hit hit = tree.closest(p);
    EXPECT_NEAR(hit.squared_distance, best, 1e-12) << "point " << i;
    EXPECT_NEAR(tree.squared_distance(p), best, 1e-12) << "point " << i;
    // The face's corners weighted by the barycentrics give the point at that distance.
    const auto& b = hit.barycentric;
    EXPECT_NEAR(b[0] + b[1] + b[2], 1.0, 1e-12);
    for (double w : b) {
      EXPECT_GE(w, 0.0);
      EXPECT_LE(w, 1.0);
    }
    const uint32_t* corner = &sphere.indices[3 * size_t(hit.face)];
    const Vec3d q = load3d(x, corner[0]) * b[0] + load3d(x, corner[1]) * b[1] + load3d(x, corner[2]) * b[2];
    EXPECT_NEAR(norm2(p - q), best, 1e-9) << "point " << i;
  }
}

TEST(ClosestPointTree, VerticesHitThemselvesAndDegenerateFacesAreLeftOut) {
  Mesh m;
  // A right triangle, then a degenerate face (three points on a line) nearer to the query.
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 2, 0, 0, 3};
  m.indices = {0, 1, 2, 3, 4, 5};
  const ClosestPointTree tree(m);
  ASSERT_FALSE(tree.empty());
  const ClosestPointTree::Hit hit = tree.closest({1, 0, 0});
  EXPECT_EQ(hit.face, 0u);
  EXPECT_NEAR(hit.barycentric[1], 1.0, 1e-12);
  EXPECT_NEAR(hit.squared_distance, 0.0, 1e-24);
  // Beside the degenerate face, the answer is still the real triangle.
  EXPECT_EQ(tree.closest({0, 0, 2.5}).face, 0u);

  Mesh line;
  line.positions = {0, 0, 0, 1, 0, 0, 2, 0, 0};
  line.indices = {0, 1, 2};
  EXPECT_TRUE(ClosestPointTree(line).empty());
}

}  // namespace
}  // namespace vpr
