// Jacobi passes of per-vertex vectors over a mesh's edges (edge_smoothing.h):
// the values of one pass by hand, a constant field kept, one result on any
// thread count, a wrong count refused. The GPU twin against this: tests/gpu.
#include "surface/edge_smoothing.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <vector>

#include "test_meshes.h"

namespace vpr {
namespace {

TEST(EdgeSmoothing, OnePassIsHalfOwnHalfTheNeighboursMean) {
  Mesh fan;  // vertex 0 in the middle of a fan of three triangles, 4 without an edge
  fan.positions.assign(3 * 5, 0.0f);
  fan.indices = {0, 1, 2, 0, 2, 3, 0, 3, 1};
  const MeshEdges edges = mesh_edges(fan);
  std::vector<Vec3d> v = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}, {5, 5, 5}};
  ASSERT_TRUE(cpu::smooth_over_edges(edges, 1, &v).ok());
  // 0: 0.5 (1,0,0) + 0.5 mean((0,1,0),(0,0,1),(0,0,0)); 1: 0.5 (0,1,0) + 0.5 mean((1,0,0),(0,0,1),(0,0,0)).
  EXPECT_DOUBLE_EQ(v[0].x, 0.5);
  EXPECT_DOUBLE_EQ(v[0].y, 0.5 / 3);
  EXPECT_DOUBLE_EQ(v[0].z, 0.5 / 3);
  EXPECT_DOUBLE_EQ(v[1].x, 0.5 / 3);
  EXPECT_DOUBLE_EQ(v[1].y, 0.5);
  EXPECT_DOUBLE_EQ(v[1].z, 0.5 / 3);
  EXPECT_DOUBLE_EQ(v[4].x, 5.0);  // no neighbour: kept
}

TEST(EdgeSmoothing, KeepsAConstantFieldAndGivesOneResultOnAnyThreadCount) {
  const Mesh sphere = testing::icosphere(4);
  const MeshEdges edges = mesh_edges(sphere);
  std::vector<Vec3d> constant(sphere.vertex_count(), Vec3d{0.25, -2, 3});
  ASSERT_TRUE(cpu::smooth_over_edges(edges, 7, &constant).ok());
  for (const Vec3d& c : constant) {
    EXPECT_NEAR(c.x, 0.25, 1e-15);
    EXPECT_NEAR(c.y, -2, 1e-14);
  }
  std::vector<Vec3d> normals(sphere.vertex_count());
  for (size_t v = 0; v < normals.size(); ++v) normals[v] = load3d(sphere.positions.data(), v);
  std::vector<Vec3d> one = normals, three = normals;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(cpu::smooth_over_edges(edges, 20, &one).ok());
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 3);
    ASSERT_TRUE(cpu::smooth_over_edges(edges, 20, &three).ok());
  }
  size_t differ = 0, moved = 0;
  for (size_t v = 0; v < one.size(); ++v) {
    differ += one[v].x != three[v].x || one[v].y != three[v].y || one[v].z != three[v].z;
    moved += norm(one[v] - normals[v]) > 1e-6;
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(moved, one.size() / 2);  // a sphere's normals shrink toward the centre as they average
  std::vector<Vec3d> wrong(3);
  EXPECT_EQ(cpu::smooth_over_edges(edges, 1, &wrong).code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace vpr
