// The edge rows on the GPU (mesh_edges.cu) against the host's (mesh_edges.cpp):
// the same offsets, neighbours and face counts, and the same corners by vertex
// as vertex_corners, on meshes with every kind of row the host meets (unused
// vertices first and last, repeated corners, an edge of three faces, a fan's
// apex of high degree) and on a refined scan; the refinement with the twin
// gives the host's surface. Bad indices and a tiny budget are errors, not
// wrong rows. Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "surface/mesh_edges.h"
#include "surface/surface_refine.h"
#include "test_meshes.h"

namespace vpr {
namespace {

class MeshEdgesGpu : public CudaTest {
 protected:
  // The GPU's rows and corners equal the host's, entry for entry.
  void expect_same(const std::vector<uint32_t>& indices, size_t vertex_count) {
    const MeshEdges host = mesh_edges(indices, vertex_count);
    const VertexCorners host_corners = vertex_corners(indices, vertex_count);
    MeshEdges gpu;
    VertexCorners gpu_corners;
    const Status status = cuda::mesh_edges(indices, vertex_count, &gpu, &gpu_corners, gpu_);
    ASSERT_TRUE(status.ok()) << status.to_string();
    EXPECT_EQ(gpu.offset, host.offset);
    EXPECT_EQ(gpu.neighbor, host.neighbor);
    EXPECT_EQ(gpu.faces, host.faces);
    ASSERT_TRUE(gpu_corners.built(vertex_count));
    EXPECT_EQ(gpu_corners.offset, host_corners.offset);
    EXPECT_EQ(gpu_corners.corner, host_corners.corner);
  }
};

TEST_F(MeshEdgesGpu, TheHostsRowsOnATorus) {
  const Mesh m = testing::torus(1.0, 0.3, 40, 60);
  expect_same(m.indices, m.vertex_count());
}

TEST_F(MeshEdgesGpu, TheHostsRowsWithUnusedVerticesRepeatedCornersAndAnEdgeOfThreeFaces) {
  // Vertices 0 and 9 unused; face (1, 1, 2) repeats a corner; edge (2, 3)
  // has three faces; (5, 6, 5) is a face with two corners the same.
  const std::vector<uint32_t> indices = {1, 2, 3, 2, 4, 3, 3, 2, 5, 1, 1, 2, 5, 6, 5, 6, 7, 8, 7, 8, 6, 3, 2, 8};
  expect_same(indices, 10);
}

TEST_F(MeshEdgesGpu, TheHostsRowsRoundAFansApex) {
  // A disc of 5,000 triangles round vertex 0: a row longer than the host's
  // insertion sort takes, and a boundary edge between each pair of rim vertices.
  std::vector<uint32_t> indices;
  const uint32_t rim = 5000;
  for (uint32_t i = 0; i < rim; ++i) indices.insert(indices.end(), {0, 1 + i, 1 + (i + 1) % rim});
  expect_same(indices, rim + 1);
}

TEST_F(MeshEdgesGpu, TheHostsRowsOnARefinedScan) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  auto refined = refine_geometry(*bunny, 0.004, 4'000'000);
  ASSERT_TRUE(refined.ok()) << refined.status().to_string();
  ASSERT_GT(refined->mesh.vertex_count(), bunny->vertex_count());
  expect_same(refined->mesh.indices, refined->mesh.vertex_count());
}

TEST_F(MeshEdgesGpu, NoFacesGiveEmptyRows) {
  MeshEdges gpu;
  VertexCorners corners;
  ASSERT_TRUE(cuda::mesh_edges({}, 4, &gpu, &corners, gpu_).ok());
  EXPECT_EQ(gpu.offset, std::vector<uint32_t>(5, 0));
  EXPECT_TRUE(gpu.neighbor.empty());
  EXPECT_EQ(corners.offset, std::vector<uint32_t>(5, 0));
}

TEST_F(MeshEdgesGpu, AnIndexPastTheVerticesIsAnError) {
  MeshEdges gpu;
  VertexCorners corners;
  const Status status = cuda::mesh_edges({0, 1, 7}, 3, &gpu, &corners, gpu_);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.to_string();
  EXPECT_NE(status.message().find("vertex count"), std::string::npos) << status.message();
}

TEST_F(MeshEdgesGpu, ATinyBudgetIsResourceExhaustedWithNothingLeftCharged) {
  const Mesh m = testing::torus(1.0, 0.3, 40, 60);
  DeviceBudget budget;
  budget.limit = 64 << 10;
  const ExecContext tight{Device::kCuda, gpu_.stream, &budget};
  MeshEdges gpu;
  VertexCorners corners;
  const Status status = cuda::mesh_edges(m.indices, m.vertex_count(), &gpu, &corners, tight);
  EXPECT_EQ(status.code(), StatusCode::kResourceExhausted) << status.to_string();
  EXPECT_EQ(budget.used.load(), 0u);
}

TEST_F(MeshEdgesGpu, TheRefinementWithTheTwinGivesTheHostsSurface) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  const EdgeBounds bounds{0.004, 0.002, 0.01};
  auto host = refine_geometry(*bunny, bounds, 4'000'000);
  ASSERT_TRUE(host.ok()) << host.status().to_string();
  const MeshEdgesTwin twin = [this](const std::vector<uint32_t>& indices, size_t n, MeshEdges* e, VertexCorners* c) {
    return cuda::mesh_edges(indices, n, e, c, gpu_);
  };
  auto gpu = refine_geometry(*bunny, bounds, 4'000'000, twin);
  ASSERT_TRUE(gpu.ok()) << gpu.status().to_string();
  EXPECT_EQ(gpu->edges_twin, "gpu");
  EXPECT_EQ(host->edges_twin, "");
  EXPECT_EQ(gpu->mesh.indices, host->mesh.indices);
  EXPECT_EQ(gpu->mesh.positions, host->mesh.positions);
  EXPECT_EQ(gpu->edges.offset, host->edges.offset);
  EXPECT_EQ(gpu->edges.neighbor, host->edges.neighbor);
  EXPECT_EQ(gpu->edges.faces, host->edges.faces);
  ASSERT_TRUE(gpu->corners.built(gpu->mesh.vertex_count()));
  EXPECT_EQ(gpu->corners.corner, vertex_corners(host->mesh.indices, host->mesh.vertex_count()).corner);
}

}  // namespace
}  // namespace vpr
