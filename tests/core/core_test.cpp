// Core types: the counter-based RNG against the published Philox answers,
// mesh validation messages, areas.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/mesh.h"
#include "core/rng.h"

namespace vpr {
namespace {

// Known-answer tests from Random123's kat_vectors for philox4x32_10.
TEST(Philox, MatchesRandom123KnownAnswers) {
  Philox4 zero = philox4x32_10(0, 0, 0, 0, 0, 0);
  EXPECT_EQ(zero.v[0], 0x6627e8d5u);
  EXPECT_EQ(zero.v[1], 0xe169c58du);
  EXPECT_EQ(zero.v[2], 0xbc57ac4cu);
  EXPECT_EQ(zero.v[3], 0x9b00dbd8u);
  Philox4 ones = philox4x32_10(~0u, ~0u, ~0u, ~0u, ~0u, ~0u);
  EXPECT_EQ(ones.v[0], 0x408f276du);
  EXPECT_EQ(ones.v[1], 0x41c83b0eu);
  EXPECT_EQ(ones.v[2], 0xa20bc7c6u);
  EXPECT_EQ(ones.v[3], 0x6d5451fdu);
  Philox4 pi = philox4x32_10(0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u, 0xa4093822u, 0x299f31d0u);
  EXPECT_EQ(pi.v[0], 0xd16cfe09u);
  EXPECT_EQ(pi.v[1], 0x94fdccebu);
  EXPECT_EQ(pi.v[2], 0x5001e420u);
  EXPECT_EQ(pi.v[3], 0x24126ea1u);
}

TEST(Philox, UniformsAreInUnitIntervalAndWellSpread) {
  double sum = 0;
  int below_tenth = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const float u = uniform01(random4(42, 7, i).v[i % 4]);
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    sum += u;
    below_tenth += u < 0.1f;
  }
  EXPECT_NEAR(sum / n, 0.5, 0.005);
  EXPECT_NEAR(double(below_tenth) / n, 0.1, 0.005);
  // Different elements and seeds give different streams.
  EXPECT_NE(random4(42, 7, 0).v[0], random4(42, 8, 0).v[0]);
  EXPECT_NE(random4(42, 7, 0).v[0], random4(43, 7, 0).v[0]);
}

Mesh unit_square() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(ValidateMesh, AcceptsASquareAndMeasuresIt) {
  const Mesh m = unit_square();
  EXPECT_TRUE(validate_mesh(m).ok());
  EXPECT_DOUBLE_EQ(total_area(m), 1.0);
  EXPECT_FLOAT_EQ(bounding_box(m).diagonal(), std::sqrt(2.0f));
  EXPECT_NEAR(mean_edge_length(m), (4 + 2 * std::sqrt(2.0)) / 6.0, 1e-12);
}

TEST(ValidateMesh, NamesEachProblem) {
  Mesh empty;
  Status s = validate_mesh(empty);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("empty"), std::string::npos);

  Mesh cloud = unit_square();
  cloud.indices.clear();
  s = validate_mesh(cloud);
  EXPECT_NE(s.message().find("point cloud"), std::string::npos) << s.message();

  Mesh nan = unit_square();
  nan.positions[4] = std::numeric_limits<float>::quiet_NaN();
  s = validate_mesh(nan);
  EXPECT_NE(s.message().find("vertex 1"), std::string::npos) << s.message();

  Mesh oob = unit_square();
  oob.indices[5] = 9;
  s = validate_mesh(oob);
  EXPECT_NE(s.message().find("references vertex 9"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("4 vertices"), std::string::npos) << s.message();

  Mesh flat = unit_square();
  for (size_t i = 0; i < 4; ++i) flat.positions[3 * i + 1] = 0;  // all on a line
  s = validate_mesh(flat);
  EXPECT_NE(s.message().find("zero area"), std::string::npos) << s.message();

  MeshLimits tiny;
  tiny.max_vertices = 3;
  s = validate_mesh(unit_square(), tiny);
  EXPECT_EQ(s.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(s.message().find("limit is 3"), std::string::npos) << s.message();
}

TEST(StatusOr, CarriesValueOrError) {
  StatusOr<int> good(5);
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(*good, 5);
  StatusOr<int> bad(invalid_argument("nope"));
  EXPECT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().to_string(), "INVALID_ARGUMENT: nope");
}

}  // namespace
}  // namespace vpr
