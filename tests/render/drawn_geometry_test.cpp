// The render's drawn geometry on the host (drawn_geometry.h): what is drawn,
// and how a GPU twin is taken or refused.
#include "render/drawn_geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_meshes.h"

namespace vpr {
namespace {

// A smooth closed sphere shares one drawn vertex per input vertex; unshared,
// every corner is drawn; the positions are relative to the box's centre.
TEST(DrawnGeometry, SharesOneVertexPerSmoothPositionAndDrawsEveryCornerOtherwise) {
  Mesh sphere = testing::icosphere(3);
  for (size_t i = 0; i < sphere.positions.size(); i += 3) sphere.positions[i] += 1000.0f;  // far off in x
  const DrawnGeometry shared = drawn_geometry(sphere, true);
  const DrawnGeometry corners = drawn_geometry(sphere, false);
  EXPECT_NEAR(shared.centre.x, 1000.0, 1e-3);
  EXPECT_EQ(shared.corners, 3 * sphere.face_count());
  EXPECT_EQ(shared.normals.size(), sphere.vertex_count());
  EXPECT_EQ(shared.indices.size(), shared.corners);
  EXPECT_EQ(corners.normals.size(), 3 * sphere.face_count());
  EXPECT_TRUE(corners.indices.empty());
  for (size_t i = 0; i < shared.normals.size(); ++i) {
    const Vec3 n = shared.normals[i];
    const Vec3 p{shared.positions[3 * i], shared.positions[3 * i + 1], shared.positions[3 * i + 2]};
    EXPECT_NEAR(norm(p), 1.0f, 1e-3f);
    EXPECT_GT(std::abs(dot(n, p)), 0.98f) << "a sphere's smooth normal is radial";
  }
  // Each shared corner's position and normal are those of the corner it stands for.
  for (size_t c = 0; c < shared.corners; ++c) {
    const uint32_t v = shared.indices[c];
    for (int k = 0; k < 3; ++k) ASSERT_EQ(shared.positions[3 * v + k], corners.positions[3 * c + k]);
    ASSERT_EQ(std::abs(shared.normals[v].x), std::abs(corners.normals[c].x));  // equal or opposite: the same gray
  }
}

TEST(DrawnGeometry, DegenerateFacesDrawNothing) {
  Mesh sphere = testing::icosphere(2);
  const size_t faces = sphere.face_count();
  sphere.indices.insert(sphere.indices.end(), {0, 0, 1, 2, 3, 2});
  const uint32_t nan_vertex = uint32_t(sphere.vertex_count());
  sphere.positions.insert(sphere.positions.end(), {NAN, 0.f, 0.f});
  sphere.indices.insert(sphere.indices.end(), {0, 1, nan_vertex});
  EXPECT_EQ(drawn_geometry(sphere, false).corners, 3 * faces);
}

// A twin's result is taken as it is; a failing twin leaves the host's
// construction and a note naming the failure; bad indices are refused before
// any twin runs.
TEST(DrawnGeometry, TakesTheTwinsResultFallsBackWhenItFailsAndChecksIndicesFirst) {
  const Mesh sphere = testing::icosphere(2);
  const DrawnGeometry host = drawn_geometry(sphere, true);
  int calls = 0;
  DrawnGeometry out;
  bool on_device = false;
  std::string note;
  const DrawnGeometryTwin marked = [&](const Mesh& m, bool indexed, DrawnGeometry* g) {
    ++calls;
    *g = drawn_geometry(m, indexed);
    g->centre.x += 1;  // marked: the twin's, not a second host call
    return Status::Ok();
  };
  ASSERT_TRUE(drawn_geometry(sphere, true, marked, &out, &on_device, &note).ok());
  EXPECT_TRUE(on_device);
  EXPECT_TRUE(note.empty());
  EXPECT_EQ(out.centre.x, host.centre.x + 1);

  const DrawnGeometryTwin failing = [&](const Mesh&, bool, DrawnGeometry*) {
    ++calls;
    return resource_exhausted("device memory: 3 MiB more would pass the job's 1 MiB budget");
  };
  ASSERT_TRUE(drawn_geometry(sphere, true, failing, &out, &on_device, &note).ok());
  EXPECT_FALSE(on_device);
  EXPECT_NE(note.find("1 MiB budget"), std::string::npos) << note;
  EXPECT_EQ(out.positions, host.positions);
  EXPECT_EQ(out.indices, host.indices);

  Mesh broken = sphere;
  broken.indices[4] = uint32_t(broken.vertex_count() + 7);
  const Status s = drawn_geometry(broken, true, marked, &out, &on_device, &note);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("out of range"), std::string::npos) << s.message();
  EXPECT_EQ(calls, 2);
}

}  // namespace
}  // namespace vpr
