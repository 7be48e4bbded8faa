// The mean curvature on the GPU (mean_curvature.cu) against the host's
// (surface_density.cpp): the same bits, |H| and its concave-weighted twin, on
// meshes with every kind of edge the host sums (unused vertices, repeated
// corners, an edge of three faces, boundary edges, a part stored inside out
// beside one stored outwards) and on a scan of 270,000 faces. Bad indices and
// a tiny budget are errors, not wrong values. Skipped where there is no CUDA
// device.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "surface/surface_density.h"
#include "test_meshes.h"

namespace vpr {
namespace {

class MeanCurvatureGpu : public CudaTest {
 protected:
  // Both twins' values, element for element, at the given concave weight;
  // some vertex must be curved, so that equal is not all zeros.
  void expect_same(const Mesh& mesh, double concave_weight) {
    std::vector<double> host_mean, host_weighted, gpu_mean, gpu_weighted;
    mean_curvatures(mesh, concave_weight, &host_mean, &host_weighted);
    const Status status = cuda::mean_curvatures(mesh, concave_weight, &gpu_mean, &gpu_weighted, gpu_);
    ASSERT_TRUE(status.ok()) << status.to_string();
    EXPECT_EQ(gpu_mean, host_mean);
    EXPECT_EQ(gpu_weighted, host_weighted);
    double largest = 0;
    for (double h : host_mean) largest = std::max(largest, h);
    EXPECT_GT(largest, 0.0);
  }
};

TEST_F(MeanCurvatureGpu, TheHostsValuesOnATorus) {
  const Mesh m = testing::torus(1.0, 0.3, 40, 60);
  expect_same(m, 0.25);
  expect_same(m, 1.0);
}

TEST_F(MeanCurvatureGpu, TheHostsValuesOnEveryKindOfEdge) {
  // Vertices 0 and 9 unused; face (1, 1, 2) repeats a corner; edge (2, 3)
  // has three faces; (5, 6, 5) has two corners the same; the rest open.
  Mesh m;
  m.positions = {0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5f, -1, 0.5f, 0.3f,
                 2, 2, 0, 2, 3, 1, 3, 2, 0.2f, 9, 9, 9};
  m.indices = {1, 2, 3, 2, 4, 3, 3, 2, 5, 1, 1, 2, 5, 6, 5, 6, 7, 8, 7, 8, 6, 3, 2, 8};
  expect_same(m, 0.25);
}

TEST_F(MeanCurvatureGpu, TheHostsValuesWithAPartInsideOutBesideOneOutwards) {
  // Two spheres, the second with its faces turned round: the concave test
  // turns round for that part alone.
  const Mesh a = testing::icosphere(3);
  Mesh b = testing::icosphere(3, 0.5f);
  for (size_t f = 0; f < b.face_count(); ++f) std::swap(b.indices[3 * f + 1], b.indices[3 * f + 2]);
  Mesh m = a;
  const uint32_t base = uint32_t(a.vertex_count());
  for (size_t i = 0; i < b.positions.size(); i += 3) {
    m.positions.push_back(b.positions[i] + 3.0f);
    m.positions.push_back(b.positions[i + 1]);
    m.positions.push_back(b.positions[i + 2]);
  }
  for (uint32_t i : b.indices) m.indices.push_back(base + i);
  expect_same(m, 0.25);
}

TEST_F(MeanCurvatureGpu, TheHostsValuesOnAScan) {
  auto igea = read_mesh("../shared/models/igea.ply");
  ASSERT_TRUE(igea.ok()) << igea.status().to_string();
  expect_same(*igea, 0.25);
}

TEST_F(MeanCurvatureGpu, NoFacesGiveZeros) {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0};
  std::vector<double> mean, weighted;
  ASSERT_TRUE(cuda::mean_curvatures(m, 0.25, &mean, &weighted, gpu_).ok());
  EXPECT_EQ(mean, std::vector<double>(2, 0.0));
  EXPECT_EQ(weighted, std::vector<double>(2, 0.0));
}

TEST_F(MeanCurvatureGpu, AnIndexPastTheVerticesIsAnError) {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.indices = {0, 1, 7};
  std::vector<double> mean, weighted;
  const Status status = cuda::mean_curvatures(m, 0.25, &mean, &weighted, gpu_);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.to_string();
  EXPECT_NE(status.message().find("vertex count"), std::string::npos) << status.message();
}

TEST_F(MeanCurvatureGpu, ATinyBudgetIsResourceExhaustedWithNothingLeftCharged) {
  const Mesh m = testing::torus(1.0, 0.3, 40, 60);
  DeviceBudget budget;
  budget.limit = 64 << 10;
  const ExecContext tight{Device::kCuda, gpu_.stream, &budget};
  std::vector<double> mean, weighted;
  const Status status = cuda::mean_curvatures(m, 0.25, &mean, &weighted, tight);
  EXPECT_EQ(status.code(), StatusCode::kResourceExhausted) << status.to_string();
  EXPECT_EQ(budget.used.load(), 0u);
}

}  // namespace
}  // namespace vpr
