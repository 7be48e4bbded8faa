// The density's curvature term: mean_curvature (surface_density.h).
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/vec3.h"
#include "surface/surface_density.h"
#include "test_meshes.h"

namespace vpr {
namespace {
using testing::icosphere;

// The definition, one half-edge at a time on one thread: faces in order for
// the areas, edges in (lower, upper) order for the integral.
std::vector<double> mean_curvature_one_edge_at_a_time(const Mesh& mesh) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<Vec3d> normal(nf);
  std::vector<double> area(nv, 0.0), integral(nv, 0.0);
  struct Half {
    uint64_t key;
    uint32_t face;
  };
  std::vector<Half> halves;
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    const Vec3d a = load3d(mesh.positions.data(), t[0]), b = load3d(mesh.positions.data(), t[1]),
                c = load3d(mesh.positions.data(), t[2]);
    const Vec3d n = cross(b - a, c - a);
    const double len = norm(n);
    normal[f] = len > 0 ? n * (1.0 / len) : Vec3d{0, 0, 0};
    for (int k = 0; k < 3; ++k) area[t[k]] += len / 6.0;
    for (int k = 0; k < 3; ++k) {
      const uint64_t u = t[k], w = t[(k + 1) % 3];
      halves.push_back({u < w ? (u << 32 | w) : (w << 32 | u), uint32_t(f)});
    }
  }
  std::sort(halves.begin(), halves.end(),
            [](const Half& x, const Half& y) { return x.key != y.key ? x.key < y.key : x.face < y.face; });
  for (size_t i = 0; i < halves.size();) {
    size_t j = i;
    while (j < halves.size() && halves[j].key == halves[i].key) ++j;
    double angle = 0;
    for (size_t p = i; p < j; ++p)
      for (size_t q = p + 1; q < j; ++q)
        angle = std::max(angle, std::acos(std::clamp(dot(normal[halves[p].face], normal[halves[q].face]), -1.0, 1.0)));
    const uint32_t u = uint32_t(halves[i].key >> 32), w = uint32_t(halves[i].key);
    const double length = norm(load3d(mesh.positions.data(), u) - load3d(mesh.positions.data(), w));
    integral[u] += 0.25 * angle * length;
    integral[w] += 0.25 * angle * length;
    i = j;
  }
  std::vector<double> h(nv, 0.0);
  for (size_t v = 0; v < nv; ++v) h[v] = area[v] > 0 ? integral[v] / area[v] : 0.0;
  return h;
}

// |H| scales as 1 / radius and stays within 1 / radius and 2/sqrt(3) times
// that all over a sphere (the dihedral estimate reads up to that factor high
// where the edges run across the curvature's directions; the density uses
// |H| over its median).
TEST(MeanCurvatureTest, SphereGivesAboutOneOverItsRadiusEverywhere) {
  const Mesh small = icosphere(4, 1.0f), large = icosphere(4, 2.0f);
  const std::vector<double> hs = mean_curvature(small), hl = mean_curvature(large);
  ASSERT_EQ(hs.size(), small.vertex_count());
  const auto [lo, hi] = std::minmax_element(hl.begin(), hl.end());
  EXPECT_GT(*lo, 0.5 * 0.98);
  EXPECT_LT(*hi, 0.5 * 1.2);
  EXPECT_LT(*hi / *lo, 1.2);
  for (size_t v = 0; v < hs.size(); ++v) EXPECT_NEAR(hs[v], 2.0 * hl[v], 1e-4) << v;
}

// A sphere with what uploads bring: a fin of three faces on one edge, a face
// with a repeated corner, a face of zero area and a vertex no face uses; the
// parallel sums give the one-thread definition's bits on any thread count.
TEST(MeanCurvatureTest, SameBitsAsOneEdgeAtATimeOnAnyThreadCount) {
  Mesh m = icosphere(3);
  const uint32_t a = m.indices[0], b = m.indices[1];
  auto add_vertex = [&](float x, float y, float z) {
    m.positions.insert(m.positions.end(), {x, y, z});
    return uint32_t(m.vertex_count() - 1);
  };
  const uint32_t fin = add_vertex(2.0f, 0.3f, -0.1f);
  const uint32_t line0 = add_vertex(0.0f, 0.0f, 3.0f), line1 = add_vertex(0.0f, 0.0f, 4.0f),
                 line2 = add_vertex(0.0f, 0.0f, 5.0f);
  add_vertex(7.0f, 7.0f, 7.0f);  // unused
  m.indices.insert(m.indices.end(), {a, b, fin});              // the edge (a, b) now has three faces
  m.indices.insert(m.indices.end(), {b, b, fin});              // a repeated corner: an edge from b to itself
  m.indices.insert(m.indices.end(), {line0, line1, line2});    // zero area
  const std::vector<double> want = mean_curvature_one_edge_at_a_time(m);
  for (int threads : {1, 2, 5}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    const std::vector<double> got = mean_curvature(m);
    ASSERT_EQ(got.size(), want.size());
    size_t differ = 0;
    for (size_t v = 0; v < want.size(); ++v)
      differ += std::memcmp(&got[v], &want[v], sizeof(double)) != 0;
    EXPECT_EQ(differ, 0u) << threads << " threads";
  }
  EXPECT_GT(want[fin], 0.0);  // the fin's edge turns
  EXPECT_EQ(want[m.vertex_count() - 1], 0.0);
}

// A unit icosphere with a Gaussian dimple of depth `depth` and angular radius
// `width` around +z: its floor is concave, the rest of the sphere convex.
Mesh dimpled_sphere(float depth, float width) {
  Mesh m = icosphere(5);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const float angle = std::acos(std::clamp(p[2], -1.0f, 1.0f));
    const float r = 1.0f - depth * std::exp(-angle * angle / (2 * width * width));
    for (int k = 0; k < 3; ++k) p[k] *= r;
  }
  return m;
}

// The convexity-weighted curvature (mean_curvatures): |H| itself with weight
// 1; on a convex surface all of |H| whatever the weight; concave edges count
// concave_weight of their term (the dimple's floor loses it, the sphere far
// from it keeps |H| bit for bit); the same values with every face turned
// round (the signed volume turns the test); and an edge whose two faces
// disagree on their orientation keeps its whole term.
TEST(MeanCurvatureTest, ConcaveEdgesCountTheirWeight) {
  const Mesh sphere = icosphere(4);
  const std::vector<double> plain = mean_curvature(sphere);
  std::vector<double> mean, weighted;
  mean_curvatures(sphere, 1.0, &mean, &weighted);
  EXPECT_EQ(mean, plain);
  EXPECT_EQ(weighted, plain);
  mean_curvatures(sphere, 0.0, &mean, &weighted);
  EXPECT_EQ(mean, plain);
  EXPECT_EQ(weighted, plain) << "a sphere has no concave edge";

  const Mesh dimpled = dimpled_sphere(0.15f, 0.2f);
  auto angle_of = [&](uint32_t v) {  // from +z, the dimple's axis
    const float* p = &dimpled.positions[3 * size_t(v)];
    return std::acos(std::clamp(p[2] / std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), -1.0f, 1.0f));
  };
  mean_curvatures(dimpled, 0.0, &mean, &weighted);
  EXPECT_EQ(mean, mean_curvature(dimpled));
  size_t floor = 0, far = 0;
  for (uint32_t v = 0; v < dimpled.vertex_count(); ++v) {
    const float angle = angle_of(v);
    if (angle < 0.1f) {  // the floor: concave all round (its curvature 0.15 / 0.2^2 less the sphere's 1)
      ++floor;
      EXPECT_GT(mean[v], 1.5) << v;
      EXPECT_LT(weighted[v], 0.05 * mean[v]) << v;
    } else if (angle > 1.0f) {  // far away: convex, untouched
      ++far;
      EXPECT_EQ(weighted[v], mean[v]) << v;
    }
  }
  EXPECT_GE(floor, 3u);
  EXPECT_GT(far, 1000u);
  std::vector<double> half;
  mean_curvatures(dimpled, 0.5, nullptr, &half);
  for (size_t v = 0; v < dimpled.vertex_count(); ++v) {
    EXPECT_LE(weighted[v], half[v]) << v;
    EXPECT_LE(half[v], mean[v]) << v;
  }

  // Turned inside out: every face reversed, the same weighted values.
  Mesh inside_out = dimpled;
  for (size_t f = 0; f < inside_out.face_count(); ++f)
    std::swap(inside_out.indices[3 * f + 1], inside_out.indices[3 * f + 2]);
  EXPECT_LT(signed_volume(inside_out), 0.0);
  EXPECT_GT(signed_volume(dimpled), 0.0);
  std::vector<double> turned;
  mean_curvatures(inside_out, 0.0, nullptr, &turned);
  for (size_t v = 0; v < dimpled.vertex_count(); ++v) EXPECT_NEAR(turned[v], weighted[v], 1e-9 * mean[v]) << v;

  // Two parts, the second an inside-out copy moved aside: each part is
  // turned round on its own, so both get the single dimpled sphere's values.
  Mesh two = dimpled;
  const uint32_t nv = uint32_t(dimpled.vertex_count());
  for (size_t v = 0; v < inside_out.vertex_count(); ++v) {
    two.positions.push_back(inside_out.positions[3 * v] + 5.0f);
    two.positions.push_back(inside_out.positions[3 * v + 1]);
    two.positions.push_back(inside_out.positions[3 * v + 2]);
  }
  for (uint32_t i : inside_out.indices) two.indices.push_back(i + nv);
  std::vector<double> both;
  mean_curvatures(two, 0.0, nullptr, &both);
  for (uint32_t v = 0; v < nv; ++v) {
    EXPECT_NEAR(both[v], weighted[v], 1e-9 * mean[v]) << v;
    EXPECT_NEAR(both[nv + v], weighted[v], 1e-3 * mean[v]) << "copy of " << v;  // moved in float: rounded
  }

  // One floor face turned round alone: its edges' faces disagree, so they keep
  // their whole terms, and its corners' values rise.
  size_t face = SIZE_MAX;
  for (size_t f = 0; f < dimpled.face_count() && face == SIZE_MAX; ++f)
    if (angle_of(dimpled.indices[3 * f]) < 0.05f && angle_of(dimpled.indices[3 * f + 1]) < 0.1f &&
        angle_of(dimpled.indices[3 * f + 2]) < 0.1f)
      face = f;
  ASSERT_NE(face, SIZE_MAX);
  Mesh one_flipped = dimpled;
  std::swap(one_flipped.indices[3 * face + 1], one_flipped.indices[3 * face + 2]);
  std::vector<double> mixed;
  mean_curvatures(one_flipped, 0.0, nullptr, &mixed);
  for (int c = 0; c < 3; ++c) {
    const uint32_t v = dimpled.indices[3 * face + c];
    EXPECT_GT(mixed[v], weighted[v] + 0.2 * mean[v]) << "corner " << v;
  }
}

// The perception density's attention term: the field's top share raised,
// from 1 at the share's edge to the boost at the top, the rest untouched;
// equal values share their rank; a non-finite value counts as the lowest.
TEST(AttentionBoostTest, RaisesOnlyTheTopShareUpToTheBoost) {
  const size_t n = 101;  // ranks 0, 0.01, ..., 1
  std::vector<float> importance(n);
  for (size_t v = 0; v < n; ++v) importance[v] = float((v * 37) % n) / float(n);  // a shuffled ramp
  const std::vector<double> flat(n, 1.0);  // |H| alike everywhere: a curvature term of 1
  AttentionBoost boost;
  boost.top = 0.2;
  boost.boost = 1.5;
  const std::vector<float> d = vertex_density(flat, importance, DensityMode::kPerception, boost);
  ASSERT_EQ(d.size(), n);
  for (size_t v = 0; v < n; ++v) {
    const double q = double((v * 37) % n) / double(n - 1);
    if (q <= 0.8 + 1e-12) EXPECT_EQ(d[v], 1.0f) << "rank " << q;
    else EXPECT_NEAR(d[v], std::pow(1.5, (q - 0.8) / 0.2), 1e-6) << "rank " << q;
  }
  EXPECT_NEAR(*std::max_element(d.begin(), d.end()), 1.5f, 1e-6);
  // Other modes ignore the field; a boost of 1 leaves the density alone.
  for (float x : vertex_density(flat, importance, DensityMode::kCurvature, boost)) EXPECT_EQ(x, 1.0f);
  boost.boost = 1;
  for (float x : vertex_density(flat, importance, DensityMode::kPerception, boost)) EXPECT_EQ(x, 1.0f);

  // Ties share their mean rank: a field of two values raises the upper half
  // alike (mean rank 0.75: 1.5^((0.75 - 0.5) / 0.5) with top 0.5); NaN and
  // infinities are the lowest.
  std::vector<float> two = {0.2f, 0.9f, 0.2f, 0.9f, NAN, 0.9f, 0.2f, 0.9f};
  two.push_back(INFINITY);
  boost.top = 0.5;
  boost.boost = 1.5;
  const std::vector<float> t = vertex_density(std::vector<double>(two.size(), 1.0), two, DensityMode::kPerception, boost);
  // Ranks: NaN and inf (tied lowest: 0 and 1 of 8), three 0.2s (2-4), four 0.9s (5-8, mean 6.5 / 8).
  EXPECT_EQ(t[4], 1.0f);
  EXPECT_EQ(t[8], 1.0f);
  EXPECT_EQ(t[0], 1.0f);
  const float upper = float(std::pow(1.5, (6.5 / 8 - 0.5) / 0.5));
  for (size_t v : {1, 3, 5, 7}) EXPECT_NEAR(t[v], upper, 1e-6) << v;

  // The options' ranges, named.
  EXPECT_TRUE(check_attention_boost(AttentionBoost{}).ok());
  const Status top = check_attention_boost(AttentionBoost{0.0, 1.5});
  EXPECT_NE(top.message().find("--attention-top"), std::string::npos) << top.to_string();
  EXPECT_NE(top.message().find("(0, 1]"), std::string::npos) << top.to_string();
  const Status high = check_attention_boost(AttentionBoost{0.2, 5});
  EXPECT_NE(high.message().find("[1, 4]"), std::string::npos) << high.to_string();
  EXPECT_FALSE(check_attention_boost(AttentionBoost{0.2, NAN}).ok());
}

}  // namespace
}  // namespace vpr
