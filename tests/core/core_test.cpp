// Core types: the counter-based RNG against the published Philox answers,
// mesh validation messages, areas, colors and textures on a mesh, the sRGB
// transfer function.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "core/color.h"
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

// A grid of n x n vertices in two triangles a square, large enough that the
// checks run in many blocks at once.
Mesh large_grid(uint32_t n) {
  Mesh m;
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) m.positions.insert(m.positions.end(), {float(x), float(y), 0.0f});
  for (uint32_t y = 0; y + 1 < n; ++y)
    for (uint32_t x = 0; x + 1 < n; ++x) {
      const uint32_t v = y * n + x;
      m.indices.insert(m.indices.end(), {v, v + 1, v + n, v + 1, v + n + 1, v + n});
    }
  return m;
}

// The checks run in parallel; the message still names the first offender,
// on any thread count.
TEST(ValidateMesh, NamesTheFirstOffenderOfALargeMesh) {
  const Mesh grid = large_grid(400);  // 160,000 vertices, 318,402 faces
  for (int threads : {1, 2, 4, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena arena(threads);
    arena.execute([&] {
      EXPECT_TRUE(validate_mesh(grid).ok());
      Mesh nan = grid;
      nan.positions[3 * 150000 + 2] = std::numeric_limits<float>::infinity();
      nan.positions[3 * 70001 + 1] = std::numeric_limits<float>::quiet_NaN();
      nan.positions[3 * 120000] = std::numeric_limits<float>::quiet_NaN();
      Status s = validate_mesh(nan);
      EXPECT_NE(s.message().find("vertex 70001 has"), std::string::npos) << threads << ": " << s.message();
      Mesh oob = grid;
      oob.indices[3 * 300000 + 1] = 160000;
      oob.indices[3 * 90000 + 2] = 170000;
      s = validate_mesh(oob);
      EXPECT_NE(s.message().find("face 90000 references vertex 170000"), std::string::npos)
          << threads << ": " << s.message();
      Mesh flat = grid;
      for (size_t i = 0; i < flat.vertex_count(); ++i) flat.positions[3 * i + 1] = 0;
      EXPECT_NE(validate_mesh(flat).message().find("zero area"), std::string::npos);
      flat.positions[3 * (400 * 399 + 399) + 1] = 1e-3f;  // one face of the last square has area
      EXPECT_TRUE(validate_mesh(flat).ok()) << threads << " threads";
    });
  }
}

// The frame (origin, scale) and positions from absolute coordinates are the
// same on any thread count, a bound of zero of either sign included.
TEST(MeshFromAbsolute, TheSameOnAnyThreadCount) {
  const Mesh grid = large_grid(300);
  std::vector<double> absolute(grid.positions.size());
  for (size_t i = 0; i < absolute.size(); ++i)
    absolute[i] = i % 3 == 2 ? (i % 2 ? -0.0 : 0.0) : 1e6 + 0.25 * double(grid.positions[i]);
  Mesh one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = mesh_from_absolute(absolute, grid.indices);
  }
  EXPECT_DOUBLE_EQ(one.origin[0], 1e6 + 0.25 * 299 / 2);
  EXPECT_EQ(std::signbit(one.origin[2]), false);
  for (int threads : {2, 4, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena arena(threads);
    Mesh m;
    arena.execute([&] { m = mesh_from_absolute(absolute, grid.indices); });
    EXPECT_EQ(m.origin, one.origin) << threads << " threads";
    EXPECT_EQ(m.scale, one.scale);
    EXPECT_EQ(0, std::memcmp(m.positions.data(), one.positions.data(), 4 * m.positions.size())) << threads;
  }
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

TEST(Mesh, UnreferencedVerticesAreDroppedInOrder) {
  Mesh m = unit_square();
  const size_t nv = m.vertex_count();
  // Strays before, between and after the used ones.
  m.positions.insert(m.positions.begin(), {9, 9, 9});
  m.positions.insert(m.positions.end(), {7, 7, 7, 8, 8, 8});
  for (uint32_t& i : m.indices) i += 1;
  const Mesh expected = unit_square();
  EXPECT_EQ(unreferenced_vertex_count(m), 3u);
  std::vector<uint32_t> used;
  EXPECT_EQ(remove_unreferenced_vertices(&m, &used), 3u);
  EXPECT_EQ(m.positions, expected.positions);
  EXPECT_EQ(m.indices, expected.indices);
  ASSERT_EQ(used.size(), nv);
  for (size_t v = 0; v < nv; ++v) EXPECT_EQ(used[v], v + 1);
  EXPECT_EQ(remove_unreferenced_vertices(&m, &used), 0u);
  EXPECT_TRUE(used.empty());
}

// A square with one color and one texture coordinate per vertex, and a 2 x 1
// texture on its vertices 1 and 3.
Mesh colored_square() {
  Mesh m = unit_square();
  m.colors = {10, 11, 12, 20, 21, 22, 30, 31, 32, 40, 41, 42};
  auto image = std::make_shared<RgbImage>(2, 1);
  m.textures.textures.push_back({image});
  m.textures.uvs = {0, 0, 1, 0, 1, 1, 0, 1};
  m.textures.vertex_texture = {MeshTextures::kNone, 0, MeshTextures::kNone, 0};
  return m;
}

TEST(Mesh, UnreferencedVerticesTakeTheirColorsAndTextureCoordinatesAlong) {
  Mesh m = colored_square();
  // A stray first: every per-vertex array shifts by one.
  m.positions.insert(m.positions.begin(), {9, 9, 9});
  m.colors.insert(m.colors.begin(), {1, 2, 3});
  m.textures.uvs.insert(m.textures.uvs.begin(), {5, 5});
  m.textures.vertex_texture.insert(m.textures.vertex_texture.begin(), 0);
  for (uint32_t& i : m.indices) i += 1;
  ASSERT_TRUE(validate_mesh(m).ok());
  EXPECT_EQ(remove_unreferenced_vertices(&m, nullptr), 1u);
  const Mesh expected = colored_square();
  EXPECT_EQ(m.colors, expected.colors);
  EXPECT_EQ(m.textures.uvs, expected.textures.uvs);
  EXPECT_EQ(m.textures.vertex_texture, expected.textures.vertex_texture);
  EXPECT_TRUE(validate_mesh(m).ok());
}

TEST(ValidateMesh, NamesEachAppearanceProblem) {
  EXPECT_TRUE(validate_mesh(colored_square()).ok());
  Mesh short_colors = colored_square();
  short_colors.colors.pop_back();
  Status s = validate_mesh(short_colors);
  EXPECT_NE(s.message().find("11 color bytes for 4 vertices"), std::string::npos) << s.message();

  Mesh bad_index = colored_square();
  bad_index.textures.vertex_texture[2] = 1;
  s = validate_mesh(bad_index);
  EXPECT_NE(s.message().find("vertex 2 uses texture 1 but the mesh has 1"), std::string::npos) << s.message();

  Mesh short_uvs = colored_square();
  short_uvs.textures.uvs.resize(6);
  s = validate_mesh(short_uvs);
  EXPECT_NE(s.message().find("3 texture coordinates"), std::string::npos) << s.message();

  Mesh no_image = colored_square();
  no_image.textures.textures[0].image = nullptr;
  s = validate_mesh(no_image);
  EXPECT_NE(s.message().find("texture 0 has no image"), std::string::npos) << s.message();

  Mesh orphan_uvs = unit_square();
  orphan_uvs.textures.uvs = {0, 0, 0, 0, 0, 0, 0, 0};
  s = validate_mesh(orphan_uvs);
  EXPECT_NE(s.message().find("texture coordinates but no textures"), std::string::npos) << s.message();
}

// IEC 61966-2-1 values, and every byte surviving the way to linear and back.
TEST(Srgb, KnownValuesAndEveryByteRoundTrips) {
  EXPECT_EQ(srgb_to_linear(0), 0.0f);
  EXPECT_EQ(srgb_to_linear(255), 1.0f);
  EXPECT_NEAR(srgb_to_linear(10), 10 / 255.0 / 12.92, 1e-9);  // the linear toe
  EXPECT_NEAR(srgb_to_linear(128), 0.2158605, 1e-6);
  EXPECT_EQ(srgb_from_linear(0.5f), 188);
  EXPECT_EQ(srgb_from_linear(0.0031308f * 0.5f), 5);  // the toe: 12.92 x 0.0015654 x 255 = 5.16
  for (int b = 0; b < 256; ++b) EXPECT_EQ(srgb_from_linear(srgb_to_linear(uint8_t(b))), b) << b;
  EXPECT_EQ(srgb_from_linear(-1.0f), 0);
  EXPECT_EQ(srgb_from_linear(2.0f), 255);
  EXPECT_EQ(srgb_from_linear(std::numeric_limits<float>::quiet_NaN()), 0);
  // Monotone: a brighter linear value never gives a darker byte.
  uint8_t last = 0;
  for (int i = 0; i <= 10000; ++i) {
    const uint8_t b = srgb_from_linear(float(i) / 10000);
    EXPECT_GE(b, last);
    last = b;
  }
}

TEST(Mesh, OriginIsTheCentreOfUsedVerticesOnlyFarFromZero) {
  // A unit triangle at 1e6 and a stray vertex at 0: the stray does not move the origin.
  const std::vector<double> far = {1e6, 1e6, 1e6, 1e6 + 1, 1e6, 1e6, 1e6, 1e6 + 1, 1e6, 0, 0, 0};
  Mesh m = mesh_from_absolute(far, {0, 1, 2});
  EXPECT_EQ(m.origin, (std::array<double, 3>{1e6 + 0.5, 1e6 + 0.5, 1e6}));
  EXPECT_DOUBLE_EQ(m.scale, std::sqrt(2.0));  // the diagonal: positions are scale-free
  EXPECT_FLOAT_EQ(m.positions[3], float(0.5 / std::sqrt(2.0)));
  for (size_t i = 0; i < 9; ++i) EXPECT_NEAR(m.absolute(i / 3, int(i % 3)), far[i], 1e-6) << i;
  EXPECT_NEAR(m.absolute(3, 0), 0.0, 1e-7 * 1e6);  // the stray: a float's precision at its distance
  EXPECT_FALSE(absolute_fits_float(m));
  // The same triangle resized by 1e-6 and moved: the same floats.
  std::vector<double> small(far.begin(), far.begin() + 9);
  for (double& x : small) x = (x - 1e6) * 1e-6 - 42;
  Mesh s = mesh_from_absolute(small, {0, 1, 2});
  EXPECT_EQ(s.positions, std::vector<float>(m.positions.begin(), m.positions.begin() + 9));
  // Near zero floats suffice for a file.
  const std::vector<double> near = {1, 1, 1, 2, 1, 1, 1, 2, 1};
  m = mesh_from_absolute(near, {0, 1, 2});
  EXPECT_TRUE(absolute_fits_float(m));
  const Mesh moved = rebased(m, {1, 1, 1}, 1);
  const std::vector<float> expected = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (size_t i = 0; i < 9; ++i) {
    EXPECT_NEAR(m.absolute(i / 3, int(i % 3)), near[i], 1e-7) << i;
    EXPECT_NEAR(moved.positions[i], expected[i], 1e-7) << i;
  }
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
