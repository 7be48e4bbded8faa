// The L2 fit's samples on the GPU (offset_match.cu) against the host's
// (offset_match.cpp): the same matches, triangles' sums and RMS sums, bit
// for bit, on a scan with openings remeshed through the CVT and its dual, and
// the same fitted mesh; a device that fails (a tiny budget) leaves the host
// to fit, with the same mesh, the failure reported and nothing left charged.
// Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "surface/cluster_mesh.h"
#include "surface/offset_match.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

bool same_bits(const OffsetMatch& a, const OffsetMatch& b) {
  return a.face == b.face && std::memcmp(&a.bary, &b.bary, sizeof a.bary) == 0 &&
         std::memcmp(&a.normal, &b.normal, sizeof a.normal) == 0 &&
         std::memcmp(&a.residual, &b.residual, sizeof a.residual) == 0 &&
         std::memcmp(&a.weight, &b.weight, sizeof a.weight) == 0;
}

class OffsetMatchGpu : public CudaTest {
 protected:
  // The CVT cells of `mesh` at `count` and their dual with the given fit.
  Mesh dual(const Mesh& mesh, uint32_t count, const ClusterMeshOptions& options, ClusterMeshStats* stats) {
    const MeshEdges edges = mesh_edges(mesh);
    std::vector<uint32_t> label;
    CvtStats cvt;
    EXPECT_TRUE(surface_cvt(mesh, edges, vertex_areas(mesh), count, CvtOptions{}, &label, &cvt).ok());
    Mesh out;
    std::vector<uint32_t> cell;
    const Status s = mesh_clusters(mesh, edges, label, cvt.clusters, &out, &cell, stats, options);
    EXPECT_TRUE(s.ok()) << s.to_string();
    return out;
  }
};

TEST_F(OffsetMatchGpu, SameMatchesSumsAndMeshAsTheHostOnAScan) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  ClusterMeshOptions on_gpu;
  int calls = 0;
  size_t matched = 0;
  on_gpu.offset.device_samples = [&](const OffsetSamples& s) -> StatusOr<std::unique_ptr<OffsetSampleSet>> {
    ++calls;
    // The matches themselves, then the sums both sets take of them.
    std::vector<OffsetMatch> host, device;
    EXPECT_TRUE(cpu::match_offset_samples(s, &host).ok());
    const Status status = cuda::match_offset_samples(s, &device, gpu_);
    EXPECT_TRUE(status.ok()) << status.to_string();
    EXPECT_EQ(device.size(), host.size());
    size_t differ = 0;
    for (size_t i = 0; i < std::min(device.size(), host.size()); ++i) {
      differ += !same_bits(device[i], host[i]);
      matched += host[i].face >= 0;
    }
    EXPECT_EQ(differ, 0u) << "of " << host.size() << " samples";
    auto cpu_set = cpu::offset_sample_set(s);
    auto gpu_set = cuda::offset_sample_set(s, gpu_);
    EXPECT_TRUE(gpu_set.ok()) << gpu_set.status().to_string();
    std::vector<OffsetFaceSums> cpu_sums, gpu_sums;
    double cpu_wr2 = 0, cpu_w = 0, gpu_wr2 = 0, gpu_w = 0;
    EXPECT_TRUE(cpu_set->match(&cpu_sums, &cpu_wr2, &cpu_w).ok());
    EXPECT_TRUE((*gpu_set)->match(&gpu_sums, &gpu_wr2, &gpu_w).ok());
    EXPECT_EQ(gpu_sums, cpu_sums);
    EXPECT_EQ(gpu_wr2, cpu_wr2);
    EXPECT_EQ(gpu_w, cpu_w);
    EXPECT_GT(cpu_w, 0);
    return cuda::offset_sample_set(s, gpu_);
  };
  ClusterMeshStats gpu_stats, cpu_stats;
  const Mesh from_gpu = dual(*bunny, 2000, on_gpu, &gpu_stats);
  const Mesh from_cpu = dual(*bunny, 2000, ClusterMeshOptions{}, &cpu_stats);
  EXPECT_EQ(calls, 1);
  EXPECT_GT(matched, bunny->face_count() / 2) << "most samples find a triangle";
  EXPECT_EQ(gpu_stats.offset.device_rounds, 1);
  EXPECT_EQ(cpu_stats.offset.device_rounds, 0);
  EXPECT_TRUE(gpu_stats.offset.device_failure.empty()) << gpu_stats.offset.device_failure;
  EXPECT_GT(gpu_stats.offset.free_vertices, 1000u);
  EXPECT_EQ(gpu_stats.offset.rms_before, cpu_stats.offset.rms_before);
  EXPECT_EQ(gpu_stats.offset.rms_after, cpu_stats.offset.rms_after);
  EXPECT_LT(cpu_stats.offset.rms_after, cpu_stats.offset.rms_before);
  EXPECT_EQ(from_gpu.positions, from_cpu.positions);
  EXPECT_EQ(from_gpu.indices, from_cpu.indices);
}

TEST_F(OffsetMatchGpu, AFailingDeviceLeavesTheHostToFitWithTheSameMesh) {
  const Mesh sphere = testing::icosphere(5);
  DeviceBudget tiny;
  tiny.limit = 4096;
  ExecContext ctx = gpu_;
  ctx.budget = &tiny;
  ClusterMeshOptions on_gpu;
  on_gpu.offset.device_samples = [&](const OffsetSamples& s) { return cuda::offset_sample_set(s, ctx); };
  ClusterMeshStats gpu_stats, cpu_stats;
  const Mesh from_gpu = dual(sphere, 500, on_gpu, &gpu_stats);
  const Mesh from_cpu = dual(sphere, 500, ClusterMeshOptions{}, &cpu_stats);
  EXPECT_EQ(gpu_stats.offset.device_rounds, 0);
  EXPECT_NE(gpu_stats.offset.device_failure.find("budget"), std::string::npos) << gpu_stats.offset.device_failure;
  EXPECT_EQ(tiny.used.load(), 0u);
  EXPECT_GT(cpu_stats.offset.free_vertices, 400u);
  EXPECT_EQ(from_gpu.positions, from_cpu.positions);
  EXPECT_EQ(from_gpu.indices, from_cpu.indices);
}

}  // namespace
}  // namespace vpr
