// The attention field's GPU twins against their CPU twins (attention_field.h,
// visibility.h): the visibility runs the same double arithmetic on both, so
// the shares must be identical; with and without the image cue,
// the weighted means run the same float products in the same order on both
// (no FMA contraction, no transcendental), so the fields must be identical.
// Skipped where no CUDA device can be used.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "../test_meshes.h"
#include "cuda_test.h"
#include "gpu/cuda_device.h"
#include "io/mesh_io.h"
#include "saliency/attention_field.h"
#include "saliency/image_saliency.h"
#include "saliency/unproject.h"
#include "saliency/visibility.h"
#include "surface/surface_density.h"

namespace vpr {
namespace {

const ExecContext kCpu{};

class AttentionFieldGpu : public CudaTest {};

void expect_twins_agree(const Mesh& m, const AttentionFieldOptions& o, const ExecContext& gpu, const std::string& what,
                        FeaturePoints features = {}) {
  const std::vector<double> hd = mean_curvature(m);
  const std::vector<float> h(hd.begin(), hd.end());
  std::vector<float> cpu_field, gpu_field;
  ASSERT_TRUE(
      cpu::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o, &cpu_field, kCpu)
          .ok());
  const Status s =
      cuda::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o, &gpu_field, gpu);
  ASSERT_TRUE(s.ok()) << s.to_string();
  ASSERT_EQ(gpu_field.size(), cpu_field.size());
  size_t differ = 0;
  double worst = 0;
  for (size_t v = 0; v < cpu_field.size(); ++v) {
    differ += gpu_field[v] != cpu_field[v];
    worst = std::max(worst, std::abs(double(gpu_field[v]) - double(cpu_field[v])));
  }
  EXPECT_EQ(differ, 0u) << what << ": largest difference " << worst;
  // The same with the grid and fine map made ahead (the pipeline's way).
  const AttentionPrep prep = prepare_attention(m.positions.data(), h.data(), m.vertex_count(), o);
  std::vector<float> prepared_field;
  ASSERT_TRUE(cuda::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o,
                                    &prepared_field, gpu, &prep)
                  .ok());
  EXPECT_EQ(prepared_field, cpu_field) << what << ", prepared ahead";
}

TEST_F(AttentionFieldGpu, EqualsCpuOnSpheresAndBunny) {
  expect_twins_agree(testing::icosphere(5), {}, gpu_, "icosphere");
  AttentionFieldOptions wide;
  wide.coarse_sigma = 0.05f;
  wide.view_bias = 0;
  expect_twins_agree(testing::icosphere(4), wide, gpu_, "icosphere, wide sigma, no bias");
  auto bunny = read_mesh("../shared/models/bunny.obj");
  if (!bunny.ok()) GTEST_SKIP() << "../shared/models/bunny.obj not found";
  expect_twins_agree(*bunny, {}, gpu_, "bunny");
}

// The cue maps and ranks run on the device too (attention_finish.cu): the
// same bits as the host's on the cases its medians and tie rule must get
// right: many equal values (one run of every vertex; a flat box whose faces
// have |H| = 0, so the coarse map's median is 0 and its positive values'
// median is used), non-finite curvature (+inf, NaN), visibility with zeros,
// -0.0, NaN and values outside [0, 1], and a single vertex.
std::vector<float> field_of(bool gpu_twin, const std::vector<float>& xyz, const std::vector<float>& h,
                            const std::vector<float>& visibility, const AttentionFieldOptions& o,
                            const ExecContext& gpu) {
  std::vector<float> field;
  const float* vis = visibility.empty() ? nullptr : visibility.data();
  const size_t n = h.size();
  const Status s = gpu_twin ? cuda::attention_field(xyz.data(), h.data(), vis, {}, n, o, &field, gpu)
                            : cpu::attention_field(xyz.data(), h.data(), vis, {}, n, o, &field, kCpu);
  EXPECT_TRUE(s.ok()) << s.to_string();
  return field;
}

TEST_F(AttentionFieldGpu, MapsAndRanksEqualCpuOnTiesZerosAndNonFiniteValues) {
  const Mesh sphere = testing::icosphere(4);
  const size_t n = sphere.vertex_count();
  const std::vector<float>& xyz = sphere.positions;
  AttentionFieldOptions flat;
  flat.view_bias = 0;
  // Every vertex the same raw value: one run, every vertex at the middle rank.
  const std::vector<float> same(n, 2.0f);
  const std::vector<float> one_run = field_of(true, xyz, same, {}, flat, gpu_);
  EXPECT_EQ(one_run, field_of(false, xyz, same, {}, flat, gpu_)) << "one run of equal values";
  ASSERT_EQ(one_run.size(), n);
  EXPECT_FLOAT_EQ(one_run[0], 0.2f + 0.8f * 0.5f);
  // Mostly zero curvature (the coarse map's median 0), a few spikes, +inf and NaN.
  std::vector<float> h(n, 0.0f);
  for (size_t v = 0; v < n; v += 17) h[v] = 0.5f + float(v % 5);
  h[3] = std::numeric_limits<float>::infinity();
  h[8] = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> visibility(n);
  for (size_t v = 0; v < n; ++v) visibility[v] = float(v % 7) / 5.0f;  // 0 .. 1.2
  visibility[1] = -0.0f;
  visibility[2] = -0.5f;
  visibility[5] = std::numeric_limits<float>::quiet_NaN();
  for (const AttentionFieldOptions& o : {AttentionFieldOptions{}, flat}) {
    EXPECT_EQ(field_of(true, xyz, h, {}, o, gpu_), field_of(false, xyz, h, {}, o, gpu_)) << "zeros and spikes";
    EXPECT_EQ(field_of(true, xyz, h, visibility, o, gpu_), field_of(false, xyz, h, visibility, o, gpu_))
        << "with visibility";
  }
  // All zero: both references 0, every map 1.
  const std::vector<float> zero(n, 0.0f);
  EXPECT_EQ(field_of(true, xyz, zero, visibility, {}, gpu_), field_of(false, xyz, zero, visibility, {}, gpu_));
  // A flat-faced box (|H| 0 inside its faces, large on its edges).
  Mesh box = testing::icosphere(3);
  for (float& c : box.positions) c = std::clamp(c * 1.6f, -1.0f, 1.0f);
  const std::vector<double> box_hd = mean_curvature(box);
  const std::vector<float> box_h(box_hd.begin(), box_hd.end());
  EXPECT_EQ(field_of(true, box.positions, box_h, {}, {}, gpu_), field_of(false, box.positions, box_h, {}, {}, gpu_))
      << "box";
  // One vertex: the maximum.
  const std::vector<float> lone_xyz = {0.5f, 0.25f, 0.0f}, lone_h = {1.0f};
  const std::vector<float> lone = field_of(true, lone_xyz, lone_h, {}, {}, gpu_);
  EXPECT_EQ(lone, field_of(false, lone_xyz, lone_h, {}, {}, gpu_));
  EXPECT_EQ(lone, std::vector<float>{1.0f});
}

// With the image cue: the weighted counts of feature points (feature_point_density)
// run the same float products on both twins, so the fields must be identical.
// The points: every view's unprojected feature pixels, as the pipeline makes them.
TEST_F(AttentionFieldGpu, ImageCueEqualsCpuOnRenderedFeatures) {
  auto renderer = create_renderer(RendererKind::kAuto);
  ASSERT_TRUE(renderer.ok()) << renderer.status().to_string();
  auto bunny = read_mesh("../shared/models/bunny.obj");
  const Mesh mesh = bunny.ok() ? *bunny : testing::icosphere(5);
  auto views = make_views(mesh, {});
  ASSERT_TRUE(views.ok());
  std::vector<Snapshot> shots;
  ASSERT_TRUE((*renderer)->render(mesh, *views, &shots).ok());
  std::vector<float> points;
  for (size_t v = 0; v < views->size(); ++v) {
    FeatureImages f;
    ASSERT_TRUE(cpu::detect_features(shots[v], {}, &f, kCpu).ok());
    ASSERT_TRUE(cpu::unproject_features(f.features, shots[v].depth, (*views)[v], &points, kCpu).ok());
  }
  ASSERT_GT(points.size(), 300u);
  const FeaturePoints features{points.data(), points.size() / 3};
  AttentionFieldOptions cue;
  cue.image_cue = true;
  expect_twins_agree(mesh, cue, gpu_, "bunny with its feature points", features);
  AttentionFieldOptions wide = cue;
  wide.coarse_sigma = 0.05f;
  expect_twins_agree(mesh, wide, gpu_, "bunny with its feature points, wide sigma", features);
}

TEST_F(AttentionFieldGpu, VisibilityEqualsCpuOnRenderedViews) {
  auto renderer = create_renderer(RendererKind::kAuto);
  ASSERT_TRUE(renderer.ok()) << renderer.status().to_string();
  auto bunny = read_mesh("../shared/models/bunny.obj");
  const Mesh mesh = bunny.ok() ? *bunny : testing::icosphere(5);
  for (int count : {6, 14}) {
    ViewOptions o;
    o.count = count;
    auto views = make_views(mesh, o);
    ASSERT_TRUE(views.ok());
    std::vector<Snapshot> shots;
    ASSERT_TRUE((*renderer)->render(mesh, *views, &shots).ok());
    std::vector<float> cpu_vis, gpu_vis;
    ASSERT_TRUE(
        cpu::view_visibility(mesh.positions.data(), mesh.vertex_count(), *views, shots, {}, &cpu_vis, kCpu).ok());
    const Status s =
        cuda::view_visibility(mesh.positions.data(), mesh.vertex_count(), *views, shots, {}, &gpu_vis, gpu_);
    ASSERT_TRUE(s.ok()) << s.to_string();
    EXPECT_EQ(gpu_vis, cpu_vis) << count << " views";
    // Views weighted towards the front and top: the same weights, summed in the same order.
    VisibilityOptions weighted;
    weighted.view_bias = 0.75f;
    ASSERT_TRUE(
        cpu::view_visibility(mesh.positions.data(), mesh.vertex_count(), *views, shots, weighted, &cpu_vis, kCpu).ok());
    ASSERT_TRUE(
        cuda::view_visibility(mesh.positions.data(), mesh.vertex_count(), *views, shots, weighted, &gpu_vis, gpu_)
            .ok());
    EXPECT_EQ(gpu_vis, cpu_vis) << count << " views, weighted";
  }
}

TEST_F(AttentionFieldGpu, RefusesLikeCpuAndRunsOutOfBudgetCleanly) {
  const Mesh m = testing::icosphere(2);
  const std::vector<double> hd = mean_curvature(m);
  const std::vector<float> h(hd.begin(), hd.end());
  std::vector<float> field;
  AttentionFieldOptions bad;
  bad.curvature_cap = 0.5f;
  EXPECT_EQ(
      cuda::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), bad, &field, gpu_).code(),
      StatusCode::kInvalidArgument);
  DeviceBudget tiny;
  tiny.limit = 64;
  const ExecContext small{Device::kCuda, gpu_.stream, &tiny};
  EXPECT_EQ(
      cuda::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), {}, &field, small).code(),
      StatusCode::kResourceExhausted);
  EXPECT_EQ(tiny.used.load(), 0u);
}

}  // namespace
}  // namespace vpr
