// The rim band (which points lie near an open edge) against a brute-force
// distance, and the refinement that keeps its elements finer there.
#include "surface/rim_band.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/mesh.h"
#include "surface/surface_refine.h"

namespace vpr {
namespace {

double distance_to_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d d = b - a;
  const double t = std::clamp(dot(p - a, d) / dot(d, d), 0.0, 1.0);
  return norm(p - (a + d * t));
}

// Random segments, some a hundred times the radius long, and points around
// them, near() against the distance to every segment; at the origin, far
// from it (cells past the grid's 21 bits share keys) and in between.
TEST(RimBand, NearIsWithinTheRadiusOfASegment) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (double shift : {0.0, 3.0e3, -7.0e6}) {
    const double radius = 0.01;
    std::vector<double> positions;
    std::vector<std::pair<uint32_t, uint32_t>> segments;
    for (uint32_t s = 0; s < 40; ++s) {
      const double length = s % 4 == 0 ? 1.0 : 0.02 * unit(rng);
      const Vec3d a{unit(rng) + shift, unit(rng), unit(rng)};
      Vec3d d{unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5};
      d = d * (length / norm(d));
      const Vec3d b = a + d;
      positions.insert(positions.end(), {a.x, a.y, a.z, b.x, b.y, b.z});
      segments.push_back({2 * s, 2 * s + 1});
    }
    const RimBand band(positions, segments, radius);
    ASSERT_FALSE(band.empty());
    size_t near = 0, checked = 0;
    for (int i = 0; i < 20000; ++i) {
      // Half the points close to a segment's point, so that both answers come often.
      Vec3d p{unit(rng) + shift, unit(rng), unit(rng)};
      if (i % 2 == 0) {
        const size_t s = size_t(i / 2) % segments.size();
        const Vec3d a{positions[6 * s], positions[6 * s + 1], positions[6 * s + 2]};
        const Vec3d b{positions[6 * s + 3], positions[6 * s + 4], positions[6 * s + 5]};
        p = a + (b - a) * unit(rng) + Vec3d{unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5} * (3 * radius);
      }
      double best = INFINITY;
      for (size_t s = 0; s < segments.size(); ++s)
        best = std::min(best, distance_to_segment(p, {positions[6 * s], positions[6 * s + 1], positions[6 * s + 2]},
                                                  {positions[6 * s + 3], positions[6 * s + 4], positions[6 * s + 5]}));
      if (std::abs(best - radius) < 1e-12 * (1 + std::abs(shift))) continue;  // a tie either way
      ++checked;
      near += best <= radius;
      ASSERT_EQ(band.near(p), best <= radius) << "shift " << shift << " point " << i << " at distance " << best;
    }
    EXPECT_GT(near, checked / 10);
    EXPECT_LT(near, checked - checked / 10);
  }
  EXPECT_FALSE(RimBand().near({0, 0, 0}));
}

// An open box, the unit cube without its bottom (y = 0), each face two
// triangles: its rim is four edges of length 1 whose ends alone are the
// cube's bottom corners.
Mesh open_box() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1, 0, 1, 0, 1, 1, 0, 1, 1, 1, 0, 1, 1};
  m.indices = {4, 7, 6, 4, 6, 5,   // top, y = 1
               0, 4, 5, 0, 5, 1,   // z = 0
               3, 2, 6, 3, 6, 7,   // z = 1
               0, 3, 7, 0, 7, 4,   // x = 0
               1, 5, 6, 1, 6, 2};  // x = 1
  return m;
}

double distance_to_rim(const Vec3d& p) {
  const Vec3d c[4] = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}};
  double best = INFINITY;
  for (int i = 0; i < 4; ++i) best = std::min(best, distance_to_segment(p, c[i], c[(i + 1) % 4]));
  return best;
}

TEST(RimBand, RefinementIsFinerNearTheRimOnly) {
  const Mesh box = open_box();
  const EdgeBounds bounds{0.2, 0.05, 0.15};
  auto banded = refine_geometry(box, bounds, 10'000'000);
  ASSERT_TRUE(banded.ok()) << banded.status().to_string();
  auto fine = refine_geometry(box, 0.05, 10'000'000);
  auto coarse = refine_geometry(box, 0.2, 10'000'000);
  ASSERT_TRUE(fine.ok() && coarse.ok());
  const Mesh& m = banded->mesh;
  double longest_near = 0, longest_far = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Vec3d a = load3d(m.positions.data(), m.indices[3 * f + c]);
      const Vec3d b = load3d(m.positions.data(), m.indices[3 * f + (c + 1) % 3]);
      const bool near = distance_to_rim(a) <= bounds.rim_band || distance_to_rim(b) <= bounds.rim_band;
      (near ? longest_near : longest_far) = std::max(near ? longest_near : longest_far, norm(a - b));
    }
  EXPECT_LE(longest_near, bounds.rim_max_edge);
  EXPECT_LE(longest_far, bounds.max_edge);
  EXPECT_GT(longest_far, bounds.rim_max_edge);  // the band is not everywhere
  EXPECT_LT(m.vertex_count(), fine->mesh.vertex_count() / 2);
  EXPECT_GT(m.vertex_count(), coarse->mesh.vertex_count());
  // The same mesh on any thread count.
  for (int threads : {1, 3}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    auto again = refine_geometry(box, bounds, 10'000'000);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again->mesh.indices, m.indices) << threads << " threads";
    EXPECT_EQ(again->mesh.positions, m.positions) << threads << " threads";
  }
}

// Rims longer than the vertex bound allows are refused before the band's
// grid is made (an upload of long open slivers cannot make it huge), with
// the bound in the message; the points counted are the grid's.
TEST(RimBand, RimsPastTheVertexBoundAreRefusedFirst) {
  const Mesh box = open_box();
  std::vector<double> pos(box.positions.begin(), box.positions.end());
  const std::vector<std::pair<uint32_t, uint32_t>> rim{{0, 1}, {1, 2}, {2, 3}, {0, 3}};
  EXPECT_DOUBLE_EQ(RimBand::points_needed(pos, rim, 0.1), 4 * 21.0);  // 20 steps of 0.05 along each
  auto refused = refine_geometry(box, EdgeBounds{0.2, 1e-4, 1e-4}, 1000);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("4 open edges would need over 1000 vertices"), std::string::npos)
      << refused.status().message();
}

// A closed surface has no rim: the band changes nothing.
TEST(RimBand, AClosedSurfaceRefinesAsWithoutTheBand) {
  Mesh box = open_box();
  box.indices.insert(box.indices.end(), {0, 1, 2, 0, 2, 3});  // the bottom, facing -y
  auto banded = refine_geometry(box, EdgeBounds{0.2, 0.05, 0.15}, 10'000'000);
  auto plain = refine_geometry(box, 0.2, 10'000'000);
  ASSERT_TRUE(banded.ok() && plain.ok());
  EXPECT_EQ(banded->mesh.indices, plain->mesh.indices);
  EXPECT_EQ(banded->mesh.positions, plain->mesh.positions);
}

}  // namespace
}  // namespace vpr
