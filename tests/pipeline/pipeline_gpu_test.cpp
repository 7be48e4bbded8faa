// The whole pipeline on the GPU against its CPU twin, the fallback when a
// stage fails on the GPU, and several jobs sharing one GPU (label gpu: run on
// the device machine by scripts/device-run.sh; skipped where no GPU answers).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "eval/hausdorff.h"
#include "io/mesh_io.h"
#include "pipeline/pipeline.h"

namespace vpr {
namespace {

constexpr uint32_t kTarget = 3000;
const char* kModel = "../shared/models/horse.ply";

class PipelineGpu : public ::testing::Test {
 protected:
  void SetUp() override {
    auto device = JobDevice::select(DevicePolicy::kCuda, 0, nullptr);
    if (!device.ok()) GTEST_SKIP() << device.status().to_string();
    auto mesh = read_mesh(kModel);
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    input_ = std::move(mesh).value();
    Vec3d lo = load3d(input_.positions.data(), 0), hi = lo;
    for (size_t v = 0; v < input_.vertex_count(); ++v) {
      const Vec3d p = load3d(input_.positions.data(), v);
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    diagonal_ = norm(hi - lo);
  }

  StatusOr<PipelineResult> run(DevicePolicy policy, DeviceBudget* budget = nullptr,
                               DensityMode density = DensityMode::kPaper, CvtSweeps sweeps = CvtSweeps::kAuto) {
    PipelineOptions options;
    options.cvt_sweeps = sweeps;
    options.target_vertices = kTarget;
    options.device = policy;
    options.device_budget = budget;
    // The paper's back half by default: the stages with whole CUDA twins
    // (the surface back half's CVT has its sweeps on the GPU, below).
    options.density = density;
    return run_pipeline(input_, options);
  }

  Mesh input_;
  double diagonal_ = 1;
};

const char* kTwinStages[] = {"image_saliency", "unproject", "saliency_field", "sampling", "awlop"};

const StageTiming* find_stage(const PipelineResult& r, const std::string& name) {
  for (const StageTiming& t : r.stages)
    if (t.name == name) return &t;
  return nullptr;
}

TEST_F(PipelineGpu, EveryTwinRunsOnTheGpuAndAgreesWithTheCpu) {
  auto gpu = run(DevicePolicy::kCuda);
  ASSERT_TRUE(gpu.ok()) << gpu.status().to_string();
  auto cpu = run(DevicePolicy::kCpu);
  ASSERT_TRUE(cpu.ok()) << cpu.status().to_string();
  EXPECT_EQ(gpu->device.rfind("cuda:0", 0), 0u) << gpu->device;
  for (const char* name : kTwinStages) {
    const StageTiming* t = find_stage(*gpu, name);
    ASSERT_NE(t, nullptr) << name;
    EXPECT_EQ(t->device, "cuda") << name << ": " << t->note;
  }
  const StageTiming* render = find_stage(*gpu, "render");
  ASSERT_NE(render, nullptr);
  EXPECT_EQ(render->note, "geometry prepared on the GPU; pixels handed to CUDA");
  // Identical feature pixels give identical saliency point counts.
  EXPECT_EQ(gpu->saliency_points, cpu->saliency_points);
  // Particles agree within 1e-4 of the diagonal (stage tests); the mesher may
  // still connect nearly equal points differently, so compare the surfaces.
  const double dv = std::abs(double(gpu->mesh.vertex_count()) - double(cpu->mesh.vertex_count()));
  EXPECT_LE(dv, 0.005 * kTarget) << gpu->mesh.vertex_count() << " vs " << cpu->mesh.vertex_count();
  ASSERT_EQ(gpu->input_importance.size(), cpu->input_importance.size());
  // Same depths on both devices; beta^d may differ in the last bit (CUDA's pow).
  size_t differ = 0;
  for (size_t i = 0; i < gpu->input_importance.size(); ++i)
    differ += std::abs(gpu->input_importance[i] - cpu->input_importance[i]) > 1e-6f;
  EXPECT_EQ(differ, 0u) << "the saliency field differs on " << differ << " vertices";
  HausdorffOptions ho;
  ho.samples_per_mesh = 50'000;
  auto h = hausdorff_distance(cpu->mesh, gpu->mesh, ho);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  EXPECT_LT(h->mean, 1e-4) << "GPU and CPU outputs differ by " << h->mean << " of the diagonal on average";
}

// The surface back half's field (the attention field) and its curvature run
// on the GPU with the CPU's arithmetic: the same field, hence the same density. The CVT's
// sweeps run in colour rounds there (cvt_sweeps.h), the CPU's sweeps
// finishing: the mesh of a CPU run with the rounds (their CPU reference),
// bit for bit. Against the CPU's sweeps alone, another local minimum of the
// same energy, compared as a surface: the count exactly, E within 2%, within
// 0.1% of the diagonal on average.
TEST_F(PipelineGpu, PerceptionDensityFieldRunsOnTheGpuAndEqualsTheCpu) {
  auto gpu = run(DevicePolicy::kCuda, nullptr, DensityMode::kPerception);
  ASSERT_TRUE(gpu.ok()) << gpu.status().to_string();
  auto cpu = run(DevicePolicy::kCpu, nullptr, DensityMode::kPerception);
  ASSERT_TRUE(cpu.ok()) << cpu.status().to_string();
  const StageTiming* t = find_stage(*gpu, "saliency_field");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->device, "cuda") << t->note;
  EXPECT_NE(t->note.find("curvature on the GPU"), std::string::npos) << t->note;
  EXPECT_EQ(gpu->input_importance, cpu->input_importance);
  const StageTiming* cvt = find_stage(*gpu, "cvt");
  ASSERT_NE(cvt, nullptr);
  EXPECT_EQ(cvt->device, "cuda") << cvt->note;
  EXPECT_NE(cvt->note.find("in colour rounds"), std::string::npos) << cvt->note;
  const StageTiming* density = find_stage(*gpu, "density");
  ASSERT_NE(density, nullptr);
  EXPECT_NE(density->note.find("edge rows made on the GPU"), std::string::npos) << density->note;
  const StageTiming* meshing = find_stage(*gpu, "meshing");
  ASSERT_NE(meshing, nullptr);
  EXPECT_NE(meshing->note.find("vertices placed and relaxed on the GPU"), std::string::npos) << meshing->note;
  auto rounds = run(DevicePolicy::kCpu, nullptr, DensityMode::kPerception, CvtSweeps::kColourRounds);
  ASSERT_TRUE(rounds.ok()) << rounds.status().to_string();
  EXPECT_EQ(rounds->mesh.positions, gpu->mesh.positions);
  EXPECT_EQ(rounds->mesh.indices, gpu->mesh.indices);
  EXPECT_EQ(rounds->cvt.energy, gpu->cvt.energy);
  auto slabs = run(DevicePolicy::kCuda, nullptr, DensityMode::kPerception, CvtSweeps::kSlabs);
  ASSERT_TRUE(slabs.ok()) << slabs.status().to_string();
  EXPECT_EQ(slabs->mesh.positions, cpu->mesh.positions);
  EXPECT_EQ(slabs->mesh.indices, cpu->mesh.indices);
  EXPECT_GT(gpu->cvt.device_sweeps, 0u);
  EXPECT_EQ(gpu->mesh.vertex_count(), cpu->mesh.vertex_count());
  EXPECT_LT(gpu->cvt.energy.back(), 1.02 * cpu->cvt.energy.back()) << gpu->cvt.energy.back() / cpu->cvt.energy.back();
  HausdorffOptions ho;
  ho.samples_per_mesh = 50'000;
  auto h = hausdorff_distance(cpu->mesh, gpu->mesh, ho);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  EXPECT_LT(h->mean, 1e-3 * diagonal_) << "GPU and CPU outputs differ by " << h->mean / diagonal_
                                       << " of the diagonal on average";
  auto again = run(DevicePolicy::kCuda, nullptr, DensityMode::kPerception);
  ASSERT_TRUE(again.ok()) << again.status().to_string();
  EXPECT_EQ(again->mesh.positions, gpu->mesh.positions);
  EXPECT_EQ(again->mesh.indices, gpu->mesh.indices);
}

// A budget too small for the CVT's device buffers: the stage reruns whole on
// the CPU, says so, and gives the GPU's mesh exactly (the rounds' CPU
// reference), so a job's result does not depend on the memory free; the
// dual's projections likewise.
TEST_F(PipelineGpu, TheCvtRerunsOnTheCpuWhenTheGpuFails) {
  DeviceBudget tiny;
  tiny.limit = 1024;
  auto fallback = run(DevicePolicy::kCuda, &tiny, DensityMode::kCurvature);
  ASSERT_TRUE(fallback.ok()) << fallback.status().to_string();
  auto gpu = run(DevicePolicy::kCuda, nullptr, DensityMode::kCurvature);
  ASSERT_TRUE(gpu.ok()) << gpu.status().to_string();
  const StageTiming* t = find_stage(*fallback, "cvt");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->device, "cpu");
  EXPECT_NE(t->note.find("RESOURCE_EXHAUSTED"), std::string::npos) << t->note;
  EXPECT_GT(fallback->cvt.device_sweeps, 0u);
  EXPECT_EQ(find_stage(*gpu, "cvt")->device, "cuda");
  // The dual's projections too: made on the host, the same mesh.
  const StageTiming* meshing = find_stage(*fallback, "meshing");
  ASSERT_NE(meshing, nullptr);
  EXPECT_NE(meshing->note.find("vertices placed and relaxed on the CPU: the GPU failed: RESOURCE_EXHAUSTED"),
            std::string::npos)
      << meshing->note;
  EXPECT_NE(find_stage(*gpu, "meshing")->note.find("vertices placed and relaxed on the GPU"), std::string::npos)
      << find_stage(*gpu, "meshing")->note;
  EXPECT_EQ(fallback->mesh.positions, gpu->mesh.positions);
  EXPECT_EQ(fallback->mesh.indices, gpu->mesh.indices);
  EXPECT_EQ(tiny.used.load(), 0u) << "every device buffer must be released";
}

TEST_F(PipelineGpu, SameInputGivesIdenticalOutputOnTheGpu) {
  auto a = run(DevicePolicy::kCuda);
  auto b = run(DevicePolicy::kCuda);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->mesh.positions, b->mesh.positions);
  EXPECT_EQ(a->mesh.indices, b->mesh.indices);
}

// A budget too small for any device buffer makes every GPU twin fail with
// RESOURCE_EXHAUSTED: each stage reruns on the CPU, says so, and the job gives
// exactly the CPU's result.
TEST_F(PipelineGpu, AStageThatFailsOnTheGpuRerunsOnTheCpu) {
  DeviceBudget tiny;
  tiny.limit = 1024;
  auto fallback = run(DevicePolicy::kCuda, &tiny);
  ASSERT_TRUE(fallback.ok()) << fallback.status().to_string();
  auto cpu = run(DevicePolicy::kCpu);
  ASSERT_TRUE(cpu.ok());
  for (const char* name : kTwinStages) {
    const StageTiming* t = find_stage(*fallback, name);
    ASSERT_NE(t, nullptr) << name;
    EXPECT_EQ(t->device, "cpu") << name;
    EXPECT_NE(t->note.find("RESOURCE_EXHAUSTED"), std::string::npos) << name << ": " << t->note;
  }
  // The render's geometry too: built on the host, the same snapshots.
  const StageTiming* render = find_stage(*fallback, "render");
  ASSERT_NE(render, nullptr);
  EXPECT_NE(render->note.find("RESOURCE_EXHAUSTED"), std::string::npos) << render->note;
  EXPECT_NE(render->note.find("geometry prepared on the host"), std::string::npos) << render->note;
  EXPECT_NE(render->note.find("pixels read back"), std::string::npos) << render->note;
  EXPECT_EQ(fallback->saliency_points, cpu->saliency_points);
  EXPECT_EQ(fallback->mesh.positions, cpu->mesh.positions);
  EXPECT_EQ(fallback->mesh.indices, cpu->mesh.indices);
  EXPECT_EQ(tiny.used.load(), 0u) << "every device buffer must be released";
}

// The snapshots handed from GL to CUDA (render/device_snapshots.h) or read
// back to the host and uploaded again: the same job, bit for bit, with the
// attention field (which reads the depth images for its visibility cue) and
// with the paper's field, and with debug output (which copies them back).
TEST_F(PipelineGpu, SnapshotsHandedToCudaGiveTheReadBacksResult) {
  for (DensityMode density : {DensityMode::kPerception, DensityMode::kPaper}) {
    SCOPED_TRACE(density == DensityMode::kPaper ? "paper" : "perception");
    PipelineOptions options;
    options.target_vertices = kTarget;
    options.device = DevicePolicy::kCuda;
    options.density = density;
    options.render_interop = false;
    auto read_back = run_pipeline(input_, options);
    ASSERT_TRUE(read_back.ok()) << read_back.status().to_string();
    options.render_interop = true;
    options.debug_dir = ::testing::TempDir() + "/interop_debug";
    auto handed = run_pipeline(input_, options);
    ASSERT_TRUE(handed.ok()) << handed.status().to_string();
    EXPECT_EQ(find_stage(*handed, "render")->note, "geometry prepared on the GPU; pixels handed to CUDA");
    EXPECT_EQ(find_stage(*read_back, "render")->note, "geometry prepared on the GPU");
    EXPECT_EQ(find_stage(*handed, "image_saliency")->device, "cuda");
    EXPECT_EQ(handed->saliency_points, read_back->saliency_points);
    EXPECT_EQ(handed->input_importance, read_back->input_importance);
    EXPECT_EQ(handed->mesh.positions, read_back->mesh.positions);
    EXPECT_EQ(handed->mesh.indices, read_back->mesh.indices);
  }
}

// A shape none of the above is, and no parameter was set on: an open box (no
// bottom: a boundary loop), with a fin 1/60 of its width thick on its lid
// (a thin part, creases), 10^4 units from the origin, as a soup with every
// other face turned over.
Mesh open_box_with_fin() {
  Mesh m;
  // An n x n grid of quads over the parallelogram o + s u + t v, s, t in [0, 1].
  auto grid = [&m](Vec3d o, Vec3d u, Vec3d v, int n) {
    const uint32_t base = uint32_t(m.vertex_count());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const Vec3d p = o + u * (double(i) / n) + v * (double(j) / n) + Vec3d{1e4, 1e4, 0};
        m.positions.insert(m.positions.end(), {float(p.x), float(p.y), float(p.z)});
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
        m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
      }
  };
  const Vec3d x{2, 0, 0}, y{0, 2, 0}, z{0, 0, 2};
  grid({0, 0, 2}, x, y, 12);  // lid
  grid({0, 0, 0}, x, z, 12);  // four sides, no bottom
  grid({0, 2, 0}, z, x, 12);
  grid({0, 0, 0}, z, y, 12);
  grid({2, 0, 0}, y, z, 12);
  const Vec3d fx{0, 0.0333, 0}, fy{1.2, 0, 0}, fz{0, 0, 0.8};  // the fin: 1.2 x 0.0333 x 0.8 on the lid
  const Vec3d f0{0.4, 0.98, 2};
  grid(f0, fy, fz, 8);
  grid(f0 + fx, fz, fy, 8);
  grid(f0, fz, fx, 2);
  grid(f0 + fy, fx, fz, 2);
  grid(f0 + fz, fx, fy, 8);
  for (size_t f = 0; f < m.indices.size() / 3; f += 2) std::swap(m.indices[3 * f + 1], m.indices[3 * f + 2]);
  return m;
}

TEST_F(PipelineGpu, SnapshotsHandedToCudaGiveTheReadBacksResultOnAnOpenBoxWithAFin) {
  const Mesh shape = open_box_with_fin();
  PipelineOptions options;
  options.target_vertices = 1500;
  options.device = DevicePolicy::kCuda;
  options.render_interop = false;
  auto read_back = run_pipeline(shape, options);
  ASSERT_TRUE(read_back.ok()) << read_back.status().to_string();
  options.render_interop = true;
  auto handed = run_pipeline(shape, options);
  ASSERT_TRUE(handed.ok()) << handed.status().to_string();
  EXPECT_NE(find_stage(*handed, "render")->note.find("pixels handed to CUDA"), std::string::npos)
      << find_stage(*handed, "render")->note;
  EXPECT_GT(handed->saliency_points, 0u);
  EXPECT_EQ(handed->saliency_points, read_back->saliency_points);
  EXPECT_EQ(handed->input_importance, read_back->input_importance);
  EXPECT_EQ(handed->mesh.positions, read_back->mesh.positions);
  EXPECT_EQ(handed->mesh.indices, read_back->mesh.indices);
}

// Four jobs on one GPU at once, each on its own stream, give the same result
// as one job alone.
TEST_F(PipelineGpu, ConcurrentJobsOnOneGpuGiveTheSingleJobResult) {
  auto alone = run(DevicePolicy::kCuda);
  ASSERT_TRUE(alone.ok()) << alone.status().to_string();
  std::vector<StatusOr<PipelineResult>> results(4, Status(StatusCode::kInternal, "not run"));
  std::vector<std::thread> threads;
  for (size_t i = 0; i < results.size(); ++i)
    threads.emplace_back([&, i] { results[i] = run(DevicePolicy::kCuda); });
  for (auto& t : threads) t.join();
  for (auto& r : results) {
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->mesh.positions, alone->mesh.positions);
    EXPECT_EQ(r->mesh.indices, alone->mesh.indices);
  }
}

}  // namespace
}  // namespace vpr
