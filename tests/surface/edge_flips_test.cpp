#include "surface/edge_flips.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "core/vec3.h"
#include "test_meshes.h"

namespace vpr {
namespace {

constexpr double kPi = 3.14159265358979323846;

Mesh mesh_of(const std::vector<Vec3d>& points, const std::vector<uint32_t>& indices) {
  Mesh m;
  for (const Vec3d& p : points) m.positions.insert(m.positions.end(), {float(p.x), float(p.y), float(p.z)});
  m.indices = indices;
  return m;
}

double smallest_angle_deg(const Mesh& m) {
  const std::vector<double> angles = testing::triangle_angles_deg(m);
  return *std::min_element(angles.begin(), angles.end());
}

std::set<std::pair<uint32_t, uint32_t>> edges_of(const Mesh& m) {
  std::set<std::pair<uint32_t, uint32_t>> e;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = m.indices[3 * f + c], b = m.indices[3 * f + (c + 1) % 3];
      e.insert({std::min(a, b), std::max(a, b)});
    }
  return e;
}

// A cap (x, y, c): c 0.02 from the middle of x-y, so its angle at c is 177.7
// degrees, in the plane z = 0; the face across x-y, (y, x, d), leans 40
// degrees out of that plane: a crease to the Delaunay flips, which keep the
// cap.
Mesh cap_beside_a_crease() {
  const double lean = 40 * kPi / 180;
  return mesh_of({{0, 0, 0}, {2, 0, 0}, {1, 0.02, 0}, {1, -std::cos(lean), std::sin(lean)}}, {0, 1, 2, 1, 0, 3});
}

// Two plane meshes: a jittered 24 x 24 grid with each square cut by a
// diagonal chosen at random (hundreds of edges whose opposite angles sum
// past pi, one pass fixes them), and 28 points on an ellipse joined as a fan
// from one of them (each flip makes the next edge one the rule flips: many
// passes, each looking only at edges next to the last pass's flips). At the
// end no interior edge may be left that the rule would flip: in a plane
// there is no crease, no fold, and c-d never exists.
TEST(EdgeFlipsTest, DelaunayFlipsLeaveNoEdgeTheRuleWouldFlip) {
  const int n = 24;
  std::vector<Vec3d> points;
  uint32_t state = 12345;
  auto random = [&] {
    state = state * 1664525u + 1013904223u;
    return double(state >> 8) / double(1u << 24);
  };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) points.push_back({i + 0.35 * (random() - 0.5), j + 0.35 * (random() - 0.5), 0});
  std::vector<uint32_t> indices;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
      if (random() < 0.5) indices.insert(indices.end(), {a, b, c, a, c, d});
      else indices.insert(indices.end(), {a, b, d, b, c, d});
    }
  Mesh m = mesh_of(points, indices);
  auto angle_at = [&](uint32_t o, uint32_t a, uint32_t b) {
    const Vec3d u = points[a] - points[o], w = points[b] - points[o];
    return std::acos(std::clamp(dot(u, w) / (norm(u) * norm(w)), -1.0, 1.0));
  };
  // Interior edges whose two opposite angles sum past pi (+ a margin over rounding).
  auto non_delaunay = [&](const Mesh& mesh) {
    std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> opposite;
    for (size_t f = 0; f < mesh.face_count(); ++f)
      for (int c = 0; c < 3; ++c) {
        const uint32_t a = mesh.indices[3 * f + c], b = mesh.indices[3 * f + (c + 1) % 3],
                       o = mesh.indices[3 * f + (c + 2) % 3];
        opposite[{std::min(a, b), std::max(a, b)}].push_back(o);
      }
    int count = 0;
    for (const auto& [e, o] : opposite)
      if (o.size() == 2 && angle_at(o[0], e.first, e.second) + angle_at(o[1], e.first, e.second) > kPi + 1e-6) ++count;
    return count;
  };
  ASSERT_GT(non_delaunay(m), 100);
  delaunay_flips(&m);
  EXPECT_EQ(non_delaunay(m), 0);
  EXPECT_EQ(m.face_count(), indices.size() / 3);

  const int k = 28;
  points.clear();
  indices.clear();
  for (int i = 0; i < k; ++i) {
    const double t = 2 * kPi * (i + 0.3 * random()) / k;
    points.push_back({3 * std::cos(t), std::sin(t), 0});
  }
  for (uint32_t i = 1; i + 1 < uint32_t(k); ++i) indices.insert(indices.end(), {0, i, i + 1});
  m = mesh_of(points, indices);
  ASSERT_GT(non_delaunay(m), 5);
  delaunay_flips(&m);
  EXPECT_EQ(non_delaunay(m), 0);
}

// A jittered n x n grid bent by 39 degrees at its middle, its vertices
// numbered at random and each square cut by a diagonal chosen at random.
Mesh bent_grid(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  std::vector<Vec3d> grid;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = i + jitter(rng), y = j + jitter(rng);
      grid.push_back({x, y, x > n / 2 ? 0.8 * (x - n / 2) : 0.0});  // a 39-degree bend at the middle
    }
  std::vector<uint32_t> number(grid.size());
  std::iota(number.begin(), number.end(), 0u);
  std::shuffle(number.begin(), number.end(), rng);
  std::vector<Vec3d> points(grid.size());
  for (size_t v = 0; v < grid.size(); ++v) points[number[v]] = grid[v];
  std::vector<uint32_t> indices;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = number[j * (n + 1) + i], b = number[j * (n + 1) + i + 1],
                     c = number[(j + 1) * (n + 1) + i + 1], d = number[(j + 1) * (n + 1) + i];
      if (rng() % 2)
        indices.insert(indices.end(), {a, b, c, a, c, d});
      else
        indices.insert(indices.end(), {a, b, d, b, c, d});
    }
  return mesh_of(points, indices);
}

// The rows a pass looks at are made per vertex from its corners (by atomic
// slots on 8 threads or more, a counting sort below): the same flips on any
// thread count. A jittered 60 x 60 grid on a bent sheet (creases refuse
// some flips) with its vertices numbered at random, so the rows' order is
// not the faces' order; each count in an arena of that many threads.
TEST(EdgeFlipsTest, TheSameFlipsOnAnyThreadCount) {
  const Mesh start = bent_grid(60, 7);
  std::vector<uint32_t> first;
  for (int threads : {1, 2, 8, 16}) {
    SCOPED_TRACE(threads);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Mesh m = start;
    tbb::task_arena(threads).execute([&] { delaunay_flips(&m); });
    if (first.empty()) {
      first = m.indices;
      EXPECT_NE(edges_of(m), edges_of(start)) << "nothing flipped: the case tests nothing";
    } else {
      EXPECT_EQ(m.indices, first);
    }
  }
}

TEST(EdgeFlipsTest, DelaunayFlipsKeepACapBesideACrease) {
  Mesh m = cap_beside_a_crease();
  delaunay_flips(&m);
  EXPECT_TRUE(edges_of(m).count({0, 1}));
  EXPECT_LT(smallest_angle_deg(m), 2.0);
}

TEST(EdgeFlipsTest, CapIsFlippedAwayAndTheSurfaceBarelyMoves) {
  Mesh m = cap_beside_a_crease();
  const double before = smallest_angle_deg(m);
  EXPECT_EQ(flip_caps(&m), 1u);
  const auto e = edges_of(m);
  EXPECT_FALSE(e.count({0, 1}));  // x-y gone
  EXPECT_TRUE(e.count({2, 3}));   // c-d made
  EXPECT_EQ(m.face_count(), 2u);
  EXPECT_GT(smallest_angle_deg(m), 10 * before);
  // Same orientation as the face it replaces: both new faces turn with (y, x, d).
  const Vec3d n_other = cross(Vec3d{-2, 0, 0}, Vec3d{-1, -std::cos(40 * kPi / 180), std::sin(40 * kPi / 180)});
  for (size_t f = 0; f < 2; ++f) {
    const Vec3d a = load3d(m.positions.data(), m.indices[3 * f]), b = load3d(m.positions.data(), m.indices[3 * f + 1]),
                c = load3d(m.positions.data(), m.indices[3 * f + 2]);
    EXPECT_GT(dot(cross(b - a, c - a), n_other), 0) << f;
  }
}

TEST(EdgeFlipsTest, CapWhoseFlipWouldFoldStays) {
  // d beside x's end, almost on the line of x-y: the quad x c y d is not
  // convex, and c-d would turn (c, x, d) over.
  Mesh m = mesh_of({{0, 0, 0}, {2, 0, 0}, {1, 0.02, 0}, {-1, -0.01, 0}}, {0, 1, 2, 1, 0, 3});
  const Mesh before = m;
  EXPECT_EQ(flip_caps(&m), 0u);
  EXPECT_EQ(m.indices, before.indices);
}

TEST(EdgeFlipsTest, PairOfCapsAndBoundaryEdgesStay) {
  // Two caps back to back (both normals meaningless) and a lone cap whose
  // long edge is on the boundary: nothing to flip.
  Mesh pair = mesh_of({{0, 0, 0}, {2, 0, 0}, {1, 0.02, 0}, {1, -0.02, 0}}, {0, 1, 2, 1, 0, 3});
  EXPECT_EQ(flip_caps(&pair), 0u);
  Mesh lone = mesh_of({{0, 0, 0}, {2, 0, 0}, {1, 0.02, 0}}, {0, 1, 2});
  EXPECT_EQ(flip_caps(&lone), 0u);
}

// The dual's runs of flips with their edge rows kept from run to run give
// the meshes that new rows give: with the vertices moved between the runs (so
// the later runs flip again), and with the kept rows then used on another
// mesh and on one whose faces changed between runs (the rows are of other
// faces there and must be made afresh).
TEST(EdgeFlipsTest, KeptRowsGiveTheFlipsOfNewRows) {
  auto wiggle = [](Mesh* m, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> d(-0.15f, 0.15f);
    for (size_t i = 0; i < m->positions.size(); i += 3) m->positions[i] += d(rng), m->positions[i + 1] += d(rng);
  };
  Mesh fresh = bent_grid(40, 3), kept_mesh = fresh;
  FlipRowsKept kept;
  delaunay_flips(&fresh);
  delaunay_flips(&kept_mesh, &kept);
  EXPECT_EQ(kept_mesh.indices, fresh.indices);
  wiggle(&fresh, 11);
  wiggle(&kept_mesh, 11);
  const std::vector<uint32_t> before = fresh.indices;
  delaunay_flips(&fresh);
  delaunay_flips(&kept_mesh, &kept);
  EXPECT_NE(fresh.indices, before) << "the second run flipped nothing: the case tests nothing";
  EXPECT_EQ(kept_mesh.indices, fresh.indices);
  EXPECT_EQ(flip_caps(&kept_mesh, &kept), flip_caps(&fresh));
  EXPECT_EQ(kept_mesh.indices, fresh.indices);

  // Another mesh of the same size, then faces changed between two runs.
  Mesh other = bent_grid(40, 5), other_kept = other;
  delaunay_flips(&other);
  delaunay_flips(&other_kept, &kept);
  EXPECT_EQ(other_kept.indices, other.indices);
  for (Mesh* m : {&other, &other_kept}) {
    std::swap(m->indices[0], m->indices[3]);  // two faces' first corners traded: other edges
    std::swap(m->indices[1], m->indices[4]);
    std::swap(m->indices[2], m->indices[5]);
    std::reverse(m->indices.begin() + 6, m->indices.begin() + 606);  // a hundred faces turned and reordered
    wiggle(m, 13);
  }
  const std::vector<uint32_t> changed = other.indices;
  delaunay_flips(&other);
  delaunay_flips(&other_kept, &kept);
  EXPECT_NE(other.indices, changed);
  EXPECT_EQ(other_kept.indices, other.indices);
}

}  // namespace
}  // namespace vpr
