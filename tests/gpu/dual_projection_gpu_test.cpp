// The dual's projections on the GPU (dual_projection.cu) against the host's:
// every placing and relaxation round gives the positions the flat-list
// projector gives on the host (flat_projector.h), bit for bit, and the dual
// the host's mesh, on a scan with openings and on a torus far from the
// origin; a device that fails (a tiny budget) leaves the host to project,
// with the same mesh, the failure reported and nothing left charged.
// Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "surface/cluster_mesh.h"
#include "surface/dual_projection.h"
#include "surface/flat_projector.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

size_t differing(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(Vec3d)) != 0;
  return n;
}

// Each call made by the device and by the host's flat-list twin, compared.
class Compared : public DualProjector {
 public:
  Compared(std::unique_ptr<DualProjector> device, const CellFaceLists& lists, testing::ProjectorCalls* calls,
           size_t* differ)
      : device_(std::move(device)), host_(lists, -1, calls), differ_(differ) {}
  Status place(const std::vector<Vec3d>& x, const std::vector<Vec3d>& start, std::vector<Vec3d>* placed) override {
    std::vector<Vec3d> host;
    VPR_RETURN_IF_ERROR(host_.place(x, start, &host));
    VPR_RETURN_IF_ERROR(device_->place(x, start, placed));
    *differ_ += differing(*placed, host);
    return Status::Ok();
  }
  Status relax(const RelaxMesh& mesh, std::vector<Vec3d>* moved) override {
    std::vector<Vec3d> host;
    VPR_RETURN_IF_ERROR(host_.relax(mesh, &host));
    VPR_RETURN_IF_ERROR(device_->relax(mesh, moved));
    *differ_ += differing(*moved, host);
    return Status::Ok();
  }

 private:
  std::unique_ptr<DualProjector> device_;
  testing::FlatProjector host_;
  size_t* differ_;
};

class DualProjectionGpu : public CudaTest {
 protected:
  Mesh dual(const Mesh& mesh, uint32_t count, const ClusterMeshOptions& options, ClusterMeshStats* stats) {
    const MeshEdges edges = mesh_edges(mesh);
    std::vector<uint32_t> label;
    CvtStats cvt;
    EXPECT_TRUE(surface_cvt(mesh, edges, vertex_areas(mesh), count, CvtOptions{}, &label, &cvt).ok());
    Mesh out;
    const Status s = mesh_clusters(mesh, edges, label, cvt.clusters, &out, nullptr, stats, options);
    EXPECT_TRUE(s.ok()) << s.to_string();
    return out;
  }
};

TEST_F(DualProjectionGpu, SamePlacesMovesAndMeshAsTheHost) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  Mesh far = testing::torus(1.0, 0.35, 64, 128);
  for (size_t i = 0; i < far.positions.size(); i += 3) far.positions[i] += 2e5f;
  for (const auto& [mesh, count] : {std::pair<const Mesh*, uint32_t>{&*bunny, 2000}, {&far, 600}}) {
    testing::ProjectorCalls calls;
    size_t differ = 0;
    ClusterMeshOptions on_gpu;
    on_gpu.device_projector = [&](const CellFaceLists& lists) -> StatusOr<std::unique_ptr<DualProjector>> {
      auto device = cuda::dual_projector(lists, gpu_);
      if (!device.ok()) return device.status();
      return std::unique_ptr<DualProjector>(
          std::make_unique<Compared>(std::move(device).value(), lists, &calls, &differ));
    };
    ClusterMeshStats gpu_stats, cpu_stats;
    const Mesh from_gpu = dual(*mesh, count, on_gpu, &gpu_stats);
    const Mesh from_cpu = dual(*mesh, count, ClusterMeshOptions{}, &cpu_stats);
    EXPECT_EQ(calls.places, 1);
    EXPECT_EQ(calls.relaxes, ClusterMeshOptions{}.relax_rounds);
    EXPECT_EQ(differ, 0u) << "positions differing from the host's";
    EXPECT_TRUE(gpu_stats.projected_on_device) << gpu_stats.projection_fallback;
    EXPECT_FALSE(cpu_stats.projected_on_device);
    EXPECT_GT(from_cpu.vertex_count(), count / 2);
    EXPECT_EQ(from_gpu.positions, from_cpu.positions);
    EXPECT_EQ(from_gpu.indices, from_cpu.indices);
  }
}

TEST_F(DualProjectionGpu, AFailingDeviceLeavesTheHostToProjectWithTheSameMesh) {
  const Mesh sphere = testing::icosphere(5);
  DeviceBudget tiny;
  tiny.limit = 4096;
  ExecContext ctx = gpu_;
  ctx.budget = &tiny;
  ClusterMeshOptions on_gpu;
  on_gpu.device_projector = [&](const CellFaceLists& lists) { return cuda::dual_projector(lists, ctx); };
  ClusterMeshStats gpu_stats, cpu_stats;
  const Mesh from_gpu = dual(sphere, 500, on_gpu, &gpu_stats);
  const Mesh from_cpu = dual(sphere, 500, ClusterMeshOptions{}, &cpu_stats);
  EXPECT_FALSE(gpu_stats.projected_on_device);
  EXPECT_NE(gpu_stats.projection_fallback.find("budget"), std::string::npos) << gpu_stats.projection_fallback;
  EXPECT_EQ(tiny.used.load(), 0u);
  EXPECT_GT(from_cpu.vertex_count(), 400u);
  EXPECT_EQ(from_gpu.positions, from_cpu.positions);
  EXPECT_EQ(from_gpu.indices, from_cpu.indices);
}

}  // namespace
}  // namespace vpr
