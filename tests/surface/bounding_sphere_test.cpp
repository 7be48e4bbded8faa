// Bounding spheres of triangles (face_sphere, surface/dual_projection.h):
// the lower bound the dual's nearest-face searches rely on, on the host and
// the device alike.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/mesh.h"
#include "core/rng.h"
#include "core/vec3.h"
#include "surface/dual_projection.h"

namespace vpr {
namespace {

// The nearest-face searches of the dual (cluster_mesh.cpp) skip a triangle
// whose bounding sphere is farther than the best distance found: that is
// exact only if the sphere's gap never exceeds the true distance, down to
// the rounding of points on the triangle and far from the origin.
TEST(BoundingSphere, HoldsItsCornersAndItsGapNeverExceedsTheDistance) {
  int no_area = 0;
  for (uint64_t i = 0; i < 2000; ++i) {
    const Philox4 r = random4(23, i, 0), s = random4(23, i, 1), t = random4(23, i, 2);
    // Triangles of sizes 1e-4 to 1 (every fifth a sliver) at offsets up to
    // 2e5 (a float's step there is 1/64, far above the smallest triangles).
    const double size = std::pow(10.0, -4.0 * uniform01(r.v[3]));
    const double offset = i % 3 == 0 ? 0.0 : 2 * std::pow(10.0, 5.0 * uniform01(s.v[3]));
    const Vec3d base = {offset, -0.5 * offset, 0.25 * offset};
    Vec3d c[3];
    for (int k = 0; k < 3; ++k) {
      const Philox4 q = random4(23, i, 3 + uint64_t(k));
      c[k] = base + Vec3d{uniform01(q.v[0]), uniform01(q.v[1]), uniform01(q.v[2])} * size;
    }
    if (i % 5 == 0) c[2] = c[0] * 0.5 + c[1] * 0.5 + Vec3d{0, 0, 1e-9 * size};
    // The corners as float positions are stored, then widened.
    float stored[9];
    for (int k = 0; k < 3; ++k) {
      stored[3 * k] = float(c[k].x);
      stored[3 * k + 1] = float(c[k].y);
      stored[3 * k + 2] = float(c[k].z);
    }
    const uint32_t triangle[3] = {0, 1, 2};
    const Vec3d a = load3d(stored, 0), b = load3d(stored, 1), e = load3d(stored, 2);
    // A triangle whose corners fall on one line in float has no area: the
    // searches never see one (a cell's faces all have area).
    if (!(norm2(cross(b - a, e - a)) > 0)) {
      ++no_area;
      continue;
    }
    const std::array<float, 4> sphere = face_sphere(stored, triangle, 0);
    // The centre is stored in float and the radius measured from it.
    for (int k = 0; k < 3; ++k) EXPECT_EQ(double(sphere[k]), double(float(sphere[k])));
    for (const Vec3d& k : {a, b, e}) EXPECT_EQ(sphere_gap2(k, sphere), 0.0) << "triangle " << i;
    // Queries on the triangle, just off it and far from it.
    for (int j = 0; j < 4; ++j) {
      const double u = uniform01(t.v[j % 4]), v = (1 - u) * uniform01(r.v[j % 3]);
      const double away = (j == 0 ? 0.0 : j == 1 ? 1e-6 : j == 2 ? 1e-2 : 100.0) * size;
      const Vec3d on = a * (1 - u - v) + b * u + e * v;
      const Vec3d p = on + Vec3d{away, -away, 0.5 * away};
      const double gap = sphere_gap2(p, sphere);
      // The gap may not exceed the distance to any point of the triangle:
      // here a grid of barycentric steps of 1/16, corners and edges included.
      double distance = INFINITY;
      for (int k = 0; k <= 16; ++k)
        for (int l = 0; k + l <= 16; ++l)
          distance = std::min(distance, norm2(p - (a * ((16 - k - l) / 16.0) + b * (k / 16.0) + e * (l / 16.0))));
      // The searches skip a triangle only when its gap exceeds the best
      // distance by more than 1e-6 of it.
      EXPECT_LE(gap, distance * (1 + 1e-6)) << "triangle " << i << " query " << j;
      if (j == 3) EXPECT_GT(gap, 0.0) << "triangle " << i << ": a point 100 sizes away is outside the sphere";
    }
  }
  EXPECT_LT(no_area, 400) << "too few triangles with an area were tried";
}

}  // namespace
}  // namespace vpr
