// The CVT's colour sweeps on the GPU (cvt_sweeps.cu) against their CPU
// reference (cvt_sweeps.cpp): the same labels and energies, bit for bit, on
// every call surface_cvt makes on a real scan with the pipeline's anisotropy
// and on a surface with an opening; a tiny device budget is RESOURCE_EXHAUSTED
// with nothing left charged. The anisotropic offsets' smoothing passes
// (edge_smoothing.cu) and the cells' growth (cell_growth.cu) the same way. Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "cuda_test.h"
#include "io/mesh_io.h"
#include "surface/cell_growth.h"
#include "surface/cvt_sweeps.h"
#include "surface/edge_smoothing.h"
#include "surface/surface_cvt.h"
#include "surface/surface_density.h"
#include "test_meshes.h"

namespace vpr {
namespace {

class CvtSweepsGpu : public CudaTest {
 protected:
  // surface_cvt with the GPU's rounds, each call checked against the CPU
  // reference on the same input; returns the calls compared.
  int run_and_compare(const Mesh& mesh, uint32_t count, double anisotropy, CvtStats* stats) {
    const MeshEdges edges = mesh_edges(mesh);
    const std::vector<double> mass = vertex_areas(mesh);
    CvtOptions options;
    options.anisotropy = anisotropy;
    int calls = 0;
    options.device_sweeps = [&](const CvtSweepInput& in, std::vector<uint32_t>* label, CvtSweepOutput* out) {
      ++calls;
      std::vector<uint32_t> reference = *label;
      CvtSweepOutput reference_out;
      EXPECT_TRUE(cpu::cvt_colour_sweeps(in, &reference, &reference_out).ok());
      const Status s = cuda::cvt_colour_sweeps(in, label, out, gpu_);
      EXPECT_TRUE(s.ok()) << s.to_string();
      EXPECT_EQ(*label, reference) << "call " << calls;
      EXPECT_EQ(out->energy, reference_out.energy) << "call " << calls;
      EXPECT_EQ(out->colours, reference_out.colours);
      EXPECT_EQ(out->moves, reference_out.moves);
      return s;
    };
    std::vector<uint32_t> label;
    EXPECT_TRUE(surface_cvt(mesh, edges, mass, count, options, &label, stats).ok());
    return calls;
  }
};

TEST_F(CvtSweepsGpu, SameLabelsAsTheCpuReferenceOnAScan) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  CvtStats stats;
  EXPECT_GE(run_and_compare(*bunny, 2000, 0.004, &stats), 1);
  EXPECT_GT(stats.device_sweeps, 2u);
  EXPECT_EQ(stats.clusters, 2000u);
}

TEST_F(CvtSweepsGpu, SameLabelsAsTheCpuReferenceWithAnOpening) {
  const Mesh sphere = testing::icosphere(5);
  Mesh open;
  open.positions = sphere.positions;
  for (size_t f = 0; f < sphere.face_count(); ++f) {
    double z = 0;
    for (int k = 0; k < 3; ++k) z += sphere.positions[3 * sphere.indices[3 * f + k] + 2] / 3.0;
    if (z < 0.6) open.indices.insert(open.indices.end(), &sphere.indices[3 * f], &sphere.indices[3 * f + 3]);
  }
  CvtStats stats;
  EXPECT_GE(run_and_compare(open, 300, 0.08, &stats), 1);
  EXPECT_GT(stats.device_sweeps, 2u);
  EXPECT_EQ(stats.defective_cells, 0u);
}

TEST_F(CvtSweepsGpu, SmoothingPassesEqualTheCpuBitForBit) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  const MeshEdges edges = mesh_edges(*bunny);
  std::vector<Vec3d> values(bunny->vertex_count());
  for (size_t v = 0; v < values.size(); ++v) values[v] = load3d(bunny->positions.data(), v);
  for (int passes : {1, 20}) {
    std::vector<Vec3d> cpu_values = values, gpu_values = values;
    ASSERT_TRUE(cpu::smooth_over_edges(edges, passes, &cpu_values).ok());
    const Status s = cuda::smooth_over_edges(edges, passes, &gpu_values, gpu_);
    ASSERT_TRUE(s.ok()) << s.to_string();
    size_t differ = 0;
    for (size_t v = 0; v < values.size(); ++v)
      differ += cpu_values[v].x != gpu_values[v].x || cpu_values[v].y != gpu_values[v].y ||
                cpu_values[v].z != gpu_values[v].z;
    EXPECT_EQ(differ, 0u) << passes << " passes";
  }
  std::vector<Vec3d> wrong(3);
  EXPECT_EQ(cuda::smooth_over_edges(edges, 1, &wrong, gpu_).code(), StatusCode::kInvalidArgument);
}

// The density's passes (surface_density.h): a float per vertex, summed in
// double, the same bits on either twin; a failing device leaves the host's.
TEST_F(CvtSweepsGpu, ScalarsSmoothAsOnTheCpuBitForBit) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  const MeshEdges edges = mesh_edges(*bunny);
  std::vector<float> values(bunny->vertex_count());
  for (size_t v = 0; v < values.size(); ++v)  // a rough field: every digit of the sums matters
    values[v] = float(std::sin(37.0 * bunny->positions[3 * v]) * std::cos(53.0 * bunny->positions[3 * v + 1]));
  for (int passes : {1, 16}) {
    std::vector<float> cpu_values = values, gpu_values = values;
    ASSERT_TRUE(cpu::smooth_over_edges(edges, passes, &cpu_values).ok());
    const Status s = cuda::smooth_over_edges(edges, passes, &gpu_values, gpu_);
    ASSERT_TRUE(s.ok()) << s.to_string();
    EXPECT_EQ(cpu_values, gpu_values) << passes << " passes";
    EXPECT_NE(cpu_values, values) << "the passes changed something";
  }
  // Through the density's entry point: one channel of two, on the device.
  std::vector<float> channels(2 * values.size()), host_channels;
  for (size_t v = 0; v < values.size(); ++v) channels[2 * v] = -1, channels[2 * v + 1] = values[v];
  host_channels = channels;
  const bool on_device = smooth_over_edges(edges, 16, 2, 1, &channels, [&](const MeshEdges& e, int p, std::vector<float>* x) {
    return cuda::smooth_over_edges(e, p, x, gpu_);
  });
  EXPECT_TRUE(on_device);
  EXPECT_FALSE(smooth_over_edges(edges, 16, 2, 1, &host_channels));
  EXPECT_EQ(channels, host_channels);
  std::vector<float> wrong(3);
  EXPECT_EQ(cuda::smooth_over_edges(edges, 1, &wrong, gpu_).code(), StatusCode::kInvalidArgument);
}

TEST_F(CvtSweepsGpu, CellsGrowAsOnTheCpuBitForBit) {
  auto bunny = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(bunny.ok()) << bunny.status().to_string();
  const MeshEdges edges = mesh_edges(*bunny);
  const size_t nv = bunny->vertex_count();
  std::vector<Vec3d> x(nv), normal(nv, Vec3d{0, 0, 0});
  for (size_t v = 0; v < nv; ++v) x[v] = load3d(bunny->positions.data(), v);
  for (size_t f = 0; f < bunny->face_count(); ++f) {
    const uint32_t* t = &bunny->indices[3 * f];
    const Vec3d n = cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]);
    for (int k = 0; k < 3; ++k) normal[t[k]] = normal[t[k]] + n;
  }
  for (Vec3d& n : normal)
    if (norm(n) > 0) n = n * (1.0 / norm(n));
  for (uint32_t stride : {37u, 1009u}) {  // many small cells; few, where the facing rule binds
    std::vector<uint32_t> seeds, start(nv, kNoCell);
    for (uint32_t v = 0; v < nv; v += stride) {
      start[v] = uint32_t(seeds.size());
      seeds.push_back(v);
    }
    CellGrowthInput in;
    in.edges = &edges;
    in.x = x.data();
    in.normal = normal.data();
    in.seeds = &seeds;
    std::vector<uint32_t> cpu_label = start, gpu_label = start;
    ASSERT_TRUE(cpu::grow_cells(in, &cpu_label).ok());
    const Status s = cuda::grow_cells(in, &gpu_label, gpu_);
    ASSERT_TRUE(s.ok()) << s.to_string();
    EXPECT_EQ(gpu_label, cpu_label) << "seeds every " << stride;
    // Reached: all but the vertices no face uses (1,113 of bunny.obj's 35,947).
    size_t unreached = 0, isolated = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      unreached += gpu_label[v] == kNoCell;
      isolated += edges.degree(v) == 0;
    }
    EXPECT_LE(unreached, isolated) << "seeds every " << stride;
    EXPECT_GT(nv - unreached, 34000u);
  }
}

TEST_F(CvtSweepsGpu, ATinyBudgetIsResourceExhaustedAndReleasesEverything) {
  const Mesh sphere = testing::icosphere(4);
  const MeshEdges edges = mesh_edges(sphere);
  const std::vector<double> mass = vertex_areas(sphere);
  DeviceBudget tiny;
  tiny.limit = 4096;
  ExecContext ctx = gpu_;
  ctx.budget = &tiny;
  CvtOptions options;
  options.device_sweeps = [&](const CvtSweepInput& in, std::vector<uint32_t>* label, CvtSweepOutput* out) {
    return cuda::cvt_colour_sweeps(in, label, out, ctx);
  };
  std::vector<uint32_t> label;
  CvtStats stats;
  const Status s = surface_cvt(sphere, edges, mass, 200, options, &label, &stats);
  EXPECT_EQ(s.code(), StatusCode::kResourceExhausted) << s.to_string();
  EXPECT_EQ(tiny.used.load(), 0u);
  std::vector<Vec3d> values(sphere.vertex_count());
  EXPECT_EQ(cuda::smooth_over_edges(edges, 3, &values, ctx).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(tiny.used.load(), 0u);
  // The density's passes: refused there, done on the host instead.
  std::vector<float> density(2 * sphere.vertex_count(), 1.0f), host;
  for (size_t v = 0; v < sphere.vertex_count(); ++v) density[2 * v + 1] = float(v % 7);
  host = density;
  EXPECT_FALSE(smooth_over_edges(edges, 3, 2, 1, &density, [&](const MeshEdges& e, int p, std::vector<float>* x) {
    return cuda::smooth_over_edges(e, p, x, ctx);
  }));
  EXPECT_EQ(tiny.used.load(), 0u);
  smooth_over_edges(edges, 3, 2, 1, &host);
  EXPECT_EQ(density, host) << "the host's passes after the device's refusal";
}

}  // namespace
}  // namespace vpr
