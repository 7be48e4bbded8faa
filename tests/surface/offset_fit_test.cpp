// The L2 fit's samples (surface/offset_match.h) as the host sums them: block
// by block, the same triangles' sums and RMS sums as the whole list of
// matches summed in sample order, on any thread count; and the RMS after the
// fit, taken from the triangles' sums, equal to the samples' own residuals.
#include "surface/offset_fit.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "surface/cluster_mesh.h"
#include "surface/mesh_edges.h"
#include "surface/offset_match.h"
#include "surface/surface_cvt.h"
#include "test_meshes.h"

namespace vpr {
namespace {

// A sphere with bumps: the dual's triangles are chords of a curved surface,
// so the samples have residuals of both signs. 81,920 faces: more samples
// than one host block.
Mesh bumpy_sphere() {
  Mesh m = testing::icosphere(6);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const float s = 1.0f + 0.08f * std::sin(5 * p[0]) * std::sin(4 * p[1] + 1) * std::cos(3 * p[2]);
    for (int k = 0; k < 3; ++k) p[k] *= s;
  }
  return m;
}

// The sums the plain way: every sample's match, then each triangle's terms
// in sample order and the RMS sums by blocks of kOffsetRmsBlock in order.
void reference_sums(const OffsetSamples& s, std::vector<OffsetFaceSums>* per_face, double* wr2, double* w) {
  std::vector<OffsetMatch> matches;
  ASSERT_TRUE(cpu::match_offset_samples(s, &matches).ok());
  per_face->assign(s.mesh->face_count(), OffsetFaceSums{});
  *wr2 = *w = 0;
  for (const OffsetMatch& m : matches)
    if (m.face >= 0) add_offset_sample(m, (*per_face)[size_t(m.face)].data());
  for (size_t b = 0; b < matches.size(); b += kOffsetRmsBlock) {
    double bw2 = 0, bw = 0;
    for (size_t i = b; i < std::min(matches.size(), b + kOffsetRmsBlock); ++i) {
      if (matches[i].face < 0) continue;
      bw2 += matches[i].weight * matches[i].residual * matches[i].residual;
      bw += matches[i].weight;
    }
    *wr2 += bw2, *w += bw;
  }
}

TEST(OffsetFit, HostBlocksSumAsTheWholeListOnAnyThreadCount) {
  const Mesh sphere = bumpy_sphere();
  ASSERT_GT(sphere.face_count(), cpu::kOffsetMatchBlock);
  const MeshEdges edges = mesh_edges(sphere);
  std::vector<uint32_t> label;
  CvtStats cvt;
  ASSERT_TRUE(surface_cvt(sphere, edges, vertex_areas(sphere), 1500, CvtOptions{}, &label, &cvt).ok());
  int calls = 0;
  ClusterMeshOptions options;
  // The fit hands its samples to a "device"; this one checks the host's set
  // against the reference and then lends the fit the host's set.
  options.offset.device_samples = [&](const OffsetSamples& s) -> StatusOr<std::unique_ptr<OffsetSampleSet>> {
    ++calls;
    std::vector<OffsetFaceSums> want;
    double want_wr2 = 0, want_w = 0;
    reference_sums(s, &want, &want_wr2, &want_w);
    EXPECT_GT(want_w, 0);
    EXPECT_GT(want_wr2, 0);
    for (int threads : {1, 2, 3}) {
      tbb::task_arena arena(threads);
      std::vector<OffsetFaceSums> got;
      double wr2 = 0, w = 0;
      arena.execute([&] { EXPECT_TRUE(cpu::offset_sample_set(s)->match(&got, &wr2, &w).ok()); });
      EXPECT_EQ(got, want) << threads << " threads";
      EXPECT_EQ(wr2, want_wr2) << threads << " threads";
      EXPECT_EQ(w, want_w) << threads << " threads";
    }
    return cpu::offset_sample_set(s);
  };
  Mesh out;
  std::vector<uint32_t> cell;
  ClusterMeshStats stats;
  ASSERT_TRUE(mesh_clusters(sphere, edges, label, cvt.clusters, &out, &cell, &stats, options).ok());
  EXPECT_EQ(calls, 1);
  EXPECT_GT(stats.offset.free_vertices, 1000u);
  EXPECT_GT(stats.offset.rms_before, 0);
  EXPECT_LT(stats.offset.rms_after, 0.8 * stats.offset.rms_before) << "the fit centres the chords on the bumps";
}

// sum w (r - sum_k b_k a_k)^2 over random samples on random triangles: by
// each sample, and from the triangles' sums (offset_wr2_change).
TEST(OffsetFit, RmsAfterFromTriangleSumsEqualsTheSamplesResiduals) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0, 1), signed_unit(-1, 1);
  const size_t triangles = 300, samples = 20000;
  std::vector<std::array<double, 3>> a(triangles);
  for (auto& t : a)
    for (double& x : t) x = 1e-3 * signed_unit(rng);
  std::vector<OffsetFaceSums> per_face(triangles, OffsetFaceSums{});
  double direct = 0, before = 0;
  for (size_t i = 0; i < samples; ++i) {
    OffsetMatch m;
    m.face = int64_t(i * 7919 % triangles);
    const double u = unit(rng), v = unit(rng) * (1 - u);
    m.bary = {u, v, 1 - u - v};
    m.residual = 2e-3 * signed_unit(rng);
    m.weight = unit(rng);
    add_offset_sample(m, per_face[size_t(m.face)].data());
    const std::array<double, 3>& move = a[size_t(m.face)];
    const double r = m.residual - (m.bary.x * move[0] + m.bary.y * move[1] + m.bary.z * move[2]);
    direct += m.weight * r * r;
    before += m.weight * m.residual * m.residual;
  }
  double from_sums = before;
  for (size_t g = 0; g < triangles; ++g) from_sums += offset_wr2_change(per_face[g], a[g]);
  EXPECT_NEAR(from_sums, direct, 1e-12 * direct);
  EXPECT_GT(std::abs(direct - before), 1e-3 * before) << "the moves change the sum";
  // No move: no change.
  double unchanged = before;
  for (size_t g = 0; g < triangles; ++g) unchanged += offset_wr2_change(per_face[g], {0, 0, 0});
  EXPECT_EQ(unchanged, before);
}

}  // namespace
}  // namespace vpr
