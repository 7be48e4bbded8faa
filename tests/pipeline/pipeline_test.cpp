// The whole pipeline on the shared scanned models and on synthetic soups.
#include "pipeline/pipeline.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>

#include "eval/hausdorff.h"
#include "eval/mesh_quality.h"
#include "io/mesh_io.h"
#include "surface/offset_fit.h"
#include "test_meshes.h"

namespace vpr {
namespace {

// Mean Hausdorff bound, in units of the bounding-box diagonal. A mesh with
// V vertices spread over area A has spacing l = sqrt(2A / (sqrt3 V)); for the
// shared models at 3000 vertices l is 1.5-3% of the diagonal, and the chordal
// error of flat triangles over surfaces with curvature radius >= 2 l is below
// l^2 / (8 R) ~ l / 16, i.e. 0.1-0.2% of the diagonal. Scans add noise the
// remesher smooths away, so allow 0.2% (measured: 0.04-0.07%).
constexpr double kMeanHausdorffBound = 0.002;
constexpr uint32_t kTarget = 3000;

PipelineOptions default_options(uint32_t target) {
  PipelineOptions o;
  o.target_vertices = target;
  return o;
}

struct ModelCase {
  const char* file;
};

class SharedModel : public ::testing::TestWithParam<ModelCase> {};

TEST_P(SharedModel, RemeshesWithinTargetAsAManifoldCloseToTheInput) {
  const std::string path = std::string("../shared/models/") + GetParam().file;
  auto input = read_mesh(path);
  ASSERT_TRUE(input.ok()) << input.status().to_string();
  auto result = run_pipeline(*input, default_options(kTarget));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  const Mesh& out = result->mesh;

  const double deviation = std::abs(double(out.vertex_count()) - kTarget) / kTarget;
  EXPECT_LE(deviation, 0.02) << out.vertex_count() << " vertices for a target of " << kTarget;

  const MeshQuality q_out = mesh_quality(out), q_in = mesh_quality(*input);
  EXPECT_EQ(q_out.non_manifold_edges, 0u);
  EXPECT_EQ(q_out.non_manifold_vertices, 0u);
  if (q_in.closed) EXPECT_TRUE(q_out.closed) << q_out.boundary_loops << " boundary loops on a closed input";

  HausdorffOptions ho;
  ho.samples_per_mesh = 50'000;
  auto h = hausdorff_distance(*input, out, ho);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  EXPECT_LT(h->mean, kMeanHausdorffBound);

  ASSERT_EQ(result->saliency.size(), out.vertex_count());
  for (float s : result->saliency) {
    ASSERT_GE(s, default_options(kTarget).field.min_importance - 1e-6f);
    ASSERT_LE(s, 1.0f + 1e-6f);
  }
  EXPECT_GT(result->saliency_points, 100u);
  std::printf(
      "%-16s in %7zu v (closed %d) -> %5zu v, mean H %.5f, max H %.5f, min angle %.1f, <30deg %.2f%%, "
      "%.0f ms\n",
      GetParam().file, input->vertex_count(), q_in.closed, out.vertex_count(), h->mean, h->max, q_out.min_angle_deg,
      100 * q_out.share_angles_below_30, result->total_ms);
}

INSTANTIATE_TEST_SUITE_P(Models, SharedModel,
                         ::testing::Values(ModelCase{"horse.ply"}, ModelCase{"kitten.obj"}, ModelCase{"fandisk.obj"},
                                           ModelCase{"bunny.obj"}, ModelCase{"beast.obj"}, ModelCase{"teapot.obj"}),
                         [](const auto& info) {
                           std::string name = info.param.file;
                           return name.substr(0, name.find('.'));
                         });

// An opening is kept exactly, rim included: the output covers the whole input
// (no notch cut into the rim) and keeps its one boundary loop. The open box
// at 200 vertices is where too few surface elements per cell (10 everywhere,
// at 41fe909) left a rim cell inside the surface: a notch 6.6% of the
// diagonal deep (docs/quality.md); the default keeps 16 near open edges.
TEST(Pipeline, OpenBoxKeepsItsRimWhole) {
  auto input = read_mesh("../shared/models/cube_no_bottom.obj");
  ASSERT_TRUE(input.ok()) << input.status().to_string();
  auto result = run_pipeline(*input, default_options(200));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  const MeshQuality q = mesh_quality(result->mesh);
  EXPECT_EQ(q.boundary_loops, 1u);
  HausdorffOptions ho;
  ho.samples_per_mesh = 50'000;
  auto h = hausdorff_distance(*input, result->mesh, ho);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  EXPECT_LT(h->forward_max, 1e-3) << "part of the input is not covered by the output";
  EXPECT_LT(h->backward_max, 1e-3) << "the output leaves the input's surface";
}

// Every density mode gives the asked vertex count within 2%, and the surface
// modes' field (the attention field) has range: at most 1% of the vertices at
// its maximum (issue 24's goal is 30%; the paper's field, kept for kPaper,
// had 50-90% on the shared models).
TEST(Pipeline, EveryDensityModeGivesTheAskedCountAndTheSurfaceModesAFieldWithRange) {
  Mesh bumpy = testing::icosphere(4);
  for (size_t v = 0; v < bumpy.vertex_count(); ++v) {
    float* p = &bumpy.positions[3 * v];
    const float r = 1.0f + 0.1f * std::exp(-((p[0] - 1) * (p[0] - 1) + p[1] * p[1] + p[2] * p[2]) / 0.05f);
    for (int k = 0; k < 3; ++k) p[k] *= r;
  }
  for (DensityMode mode :
       {DensityMode::kPerception, DensityMode::kCurvature, DensityMode::kUniform, DensityMode::kPaper}) {
    PipelineOptions o = default_options(1000);
    o.density = mode;
    auto result = run_pipeline(bumpy, o);
    ASSERT_TRUE(result.ok()) << density_mode_name(mode) << ": " << result.status().to_string();
    const double deviation = std::abs(double(result->mesh.vertex_count()) - 1000.0) / 1000.0;
    EXPECT_LE(deviation, 0.02) << density_mode_name(mode) << ": " << result->mesh.vertex_count() << " vertices";
    const std::vector<float>& f = result->input_importance;
    ASSERT_EQ(f.size(), bumpy.vertex_count());
    const float top = *std::max_element(f.begin(), f.end());
    const double at_max =
        double(std::count_if(f.begin(), f.end(), [&](float x) { return x >= top - 1e-6f; })) / double(f.size());
    if (mode != DensityMode::kPaper) EXPECT_LE(at_max, 0.01) << density_mode_name(mode);
  }
}

// An attention map replaces the field (reported as the field, per given
// vertex, a dropped unused vertex at the floor) and the perception density
// spends more vertices where the map is high: a cap of the sphere gets more
// output vertices when the map marks it than when the map marks the opposite
// cap. A map of the wrong size, or with a NaN, is refused naming the problem.
TEST(Pipeline, AnAttentionMapReplacesTheFieldAndDrawsVerticesToWhereItIsHigh) {
  const Mesh sphere = testing::icosphere(4);
  // The given mesh: an unused vertex first, so the map's indices differ from
  // the compacted input's.
  Mesh given;
  given.positions = {5.0f, 5.0f, 5.0f};
  given.positions.insert(given.positions.end(), sphere.positions.begin(), sphere.positions.end());
  for (uint32_t i : sphere.indices) given.indices.push_back(i + 1);
  const size_t n = given.vertex_count();
  auto cap_map = [&](float side) {
    auto map = std::make_shared<std::vector<float>>(n, 0.0f);
    (*map)[0] = 100.0f;  // dropped with its vertex
    for (size_t v = 1; v < n; ++v)
      if (side * given.positions[3 * v] > 0.6f) (*map)[v] = 1.0f + given.positions[3 * v + 1];
    return map;
  };
  auto in_cap = [](const Mesh& m, float side) {
    size_t k = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) k += side * m.positions[3 * v] > 0.6f;
    return k;
  };
  PipelineOptions o = default_options(600);
  o.density = DensityMode::kPerception;
  o.attention_boost = {0.2, 2.0};
  o.attention_map = cap_map(1.0f);
  auto plus = run_pipeline(given, o);
  ASSERT_TRUE(plus.ok()) << plus.status().to_string();
  ASSERT_EQ(plus->input_importance.size(), n);
  EXPECT_EQ(plus->input_importance[0], o.field.min_importance);
  for (size_t v = 1; v < n; ++v) ASSERT_EQ(plus->input_importance[v], (*o.attention_map)[v]) << v;
  o.attention_map = cap_map(-1.0f);
  auto minus = run_pipeline(given, o);
  ASSERT_TRUE(minus.ok()) << minus.status().to_string();
  EXPECT_GT(double(in_cap(plus->mesh, 1.0f)), 1.3 * double(in_cap(minus->mesh, 1.0f)));
  EXPECT_GT(double(in_cap(minus->mesh, -1.0f)), 1.3 * double(in_cap(plus->mesh, -1.0f)));

  o.attention_map = std::make_shared<std::vector<float>>(n - 1, 0.0f);
  auto wrong = run_pipeline(given, o);
  ASSERT_FALSE(wrong.ok());
  EXPECT_EQ(wrong.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(wrong.status().message().find(std::to_string(n - 1) + " values for a mesh of " + std::to_string(n)),
            std::string::npos)
      << wrong.status().message();
  auto nan = std::make_shared<std::vector<float>>(n, 0.0f);
  (*nan)[7] = std::nanf("");
  o.attention_map = nan;
  wrong = run_pipeline(given, o);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().message().find("value 7 is not a finite number"), std::string::npos)
      << wrong.status().message();
}

TEST(Pipeline, SameSeedGivesIdenticalOutputAtOneAndTwoThreads) {
  auto input = read_mesh("../shared/models/kitten.obj");
  ASSERT_TRUE(input.ok()) << input.status().to_string();
  Mesh one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    auto r = run_pipeline(*input, default_options(2000));
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    one = r->mesh;
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    auto r = run_pipeline(*input, default_options(2000));
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    two = r->mesh;
  }
  EXPECT_EQ(one.positions, two.positions);
  EXPECT_EQ(one.indices, two.indices);

  PipelineOptions other = default_options(2000);
  other.sampling.seed = 99;
  auto r = run_pipeline(*input, other);
  ASSERT_TRUE(r.ok());
  EXPECT_NE(r->mesh.positions, one.positions);
}

// The CVT's sweeps in colour rounds (the GPU path's CVT, here its CPU
// reference) on a scan with holes: the count exactly, a manifold keeping
// its boundary loops, as close to the input as the CPU's sweeps alone, another mesh than
// theirs, and the same on one and two threads.
TEST(Pipeline, ColourRoundsGiveTheGpuPathsMeshOnAnyThreadCount) {
  auto input = read_mesh("../shared/models/bunny.obj");
  ASSERT_TRUE(input.ok()) << input.status().to_string();
  PipelineOptions rounds = default_options(2000);
  rounds.cvt_sweeps = CvtSweeps::kColourRounds;
  auto slabs = run_pipeline(*input, default_options(2000));
  ASSERT_TRUE(slabs.ok()) << slabs.status().to_string();
  Mesh one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    auto r = run_pipeline(*input, rounds);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    one = r->mesh;
  }
  auto r = run_pipeline(*input, rounds);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->mesh.positions, one.positions);
  EXPECT_EQ(r->mesh.indices, one.indices);
  EXPECT_NE(r->mesh.positions, slabs->mesh.positions);
  EXPECT_EQ(r->mesh.vertex_count(), 2000u);
  EXPECT_GT(r->cvt.device_sweeps, 0u);
  EXPECT_EQ(slabs->cvt.device_sweeps, 0u);
  EXPECT_LT(r->cvt.energy.back(), 1.02 * slabs->cvt.energy.back());
  const MeshQuality q = mesh_quality(r->mesh), qs = mesh_quality(slabs->mesh);
  EXPECT_EQ(q.non_manifold_edges, 0u);
  EXPECT_EQ(q.boundary_loops, qs.boundary_loops);
  EXPECT_GT(q.boundary_loops, 0u);
  HausdorffOptions ho;
  ho.samples_per_mesh = 50'000;
  auto h = hausdorff_distance(*input, r->mesh, ho), hs = hausdorff_distance(*input, slabs->mesh, ho);
  ASSERT_TRUE(h.ok() && hs.ok());
  EXPECT_LT(h->mean, 1.1 * hs->mean) << h->mean << " against " << hs->mean;
}

TEST(Pipeline, PolygonSoupOfASphereGivesAClosedGenusZeroMesh) {
  const Mesh soup = testing::flipped_soup(testing::icosphere(4));
  auto result = run_pipeline(soup, default_options(1000));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  const MeshQuality q = mesh_quality(result->mesh);
  EXPECT_TRUE(q.closed);
  EXPECT_EQ(q.euler_characteristic, 2);
  EXPECT_EQ(q.components, 1u);
  EXPECT_NEAR(double(result->mesh.vertex_count()), 1000.0, 20.0);
}

TEST(Pipeline, RejectsImpossibleTargetsAndOptionsWithTheLimit) {
  const Mesh sphere = testing::icosphere(2);
  auto r = run_pipeline(sphere, default_options(5));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("[100, 2000000]"), std::string::npos) << r.status().message();

  PipelineOptions views = default_options(1000);
  views.views.count = 7;
  r = run_pipeline(sphere, views);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("6 or 14"), std::string::npos);

  PipelineOptions elements = default_options(1000);
  elements.cvt_elements_per_vertex = 0;
  r = run_pipeline(sphere, elements);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("[4, 64]"), std::string::npos) << r.status().message();
  elements = default_options(1000);
  elements.cvt_rim_band = std::nan("");
  r = run_pipeline(sphere, elements);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("[0, 16]"), std::string::npos) << r.status().message();

  Mesh cloud = sphere;
  cloud.indices.clear();
  r = run_pipeline(cloud, default_options(1000));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("point cloud"), std::string::npos);
}

// No tolerance may depend on the model's units: the same sphere in
// micrometres, far from the origin, and at astronomical size remeshes like the
// unit sphere (same vertex count, same distance from the surface).
TEST(Pipeline, ResultDoesNotDependOnTheModelsUnitsOrPlacement) {
  const Mesh unit = testing::icosphere(4);
  auto max_radius_error = [](const Mesh& m, double scale, double offset) {
    double worst = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double x = (double(m.positions[3 * v + a]) - offset) / scale;
        d2 += x * x;
      }
      worst = std::max(worst, std::abs(std::sqrt(d2) - 1.0));
    }
    return worst;
  };
  auto reference = run_pipeline(unit, default_options(800));
  ASSERT_TRUE(reference.ok()) << reference.status().to_string();
  // AWLOP's repulsion has a normal component on a curved surface: at 800
  // points on the unit sphere it leaves particles up to ~1.1% outside.
  const double reference_error = max_radius_error(reference->mesh, 1.0, 0.0);
  EXPECT_LT(reference_error, 0.02);
  for (const auto& [scale, offset] : {std::pair{1e-6, 0.0}, std::pair{1.0, 1e4}, std::pair{1e30, 0.0}}) {
    Mesh m = unit;
    for (size_t i = 0; i < m.positions.size(); ++i) m.positions[i] = float(m.positions[i] * scale + offset);
    auto r = run_pipeline(m, default_options(800));
    ASSERT_TRUE(r.ok()) << "scale " << scale << ": " << r.status().to_string();
    EXPECT_NEAR(double(r->mesh.vertex_count()), double(reference->mesh.vertex_count()), 8.0) << "scale " << scale;
    EXPECT_TRUE(mesh_quality(r->mesh).closed) << "scale " << scale;
    EXPECT_NEAR(max_radius_error(r->mesh, scale, offset), reference_error, 0.003) << "scale " << scale;
  }
}

// The sphere (centre, radius) whose surface is nearest to p, and p's distance to its centre.
std::pair<int, double> nearest_sphere(const float* p, const std::vector<std::array<double, 4>>& spheres) {
  int best = 0;
  double best_gap = 1e300, best_d = 0;
  for (size_t i = 0; i < spheres.size(); ++i) {
    const double dx = p[0] - spheres[i][0], dy = p[1] - spheres[i][1], dz = p[2] - spheres[i][2];
    const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (std::abs(d - spheres[i][3]) < best_gap) best_gap = std::abs(d - spheres[i][3]), best = int(i), best_d = d;
  }
  return {best, best_d};
}

std::vector<int> per_sphere_counts(const Mesh& m, const std::vector<std::array<double, 4>>& spheres) {
  std::vector<int> count(spheres.size(), 0);
  for (size_t v = 0; v < m.vertex_count(); ++v) ++count[nearest_sphere(&m.positions[3 * v], spheres).first];
  return count;
}

// Issue 19, part 3: 100 spheres with radii spread over two orders of
// magnitude (0.01 to 1, log-spaced) keep 100 closed parts, each on its own
// sphere; the smallest get their equal share of the target
// (CvtOptions::equal_part_share), not the few cells their area would buy.
TEST(Pipeline, ManySpheresOfManySizesKeepEveryPartClosedAndInPlace) {
  const Mesh unit = testing::icosphere(2);
  constexpr int kParts = 100;
  Mesh kit;
  std::vector<std::array<double, 4>> spheres;  // centre, radius
  for (int i = 0; i < kParts; ++i) {
    const double r = std::pow(10.0, -2.0 + 2.0 * i / (kParts - 1));
    const double c[3] = {2.5 * (i % 10), 2.5 * (i / 10), 0.0};
    spheres.push_back({c[0], c[1], c[2], r});
    const uint32_t base = uint32_t(kit.vertex_count());
    for (size_t v = 0; v < unit.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) kit.positions.push_back(float(c[a] + r * unit.positions[3 * v + a]));
    for (uint32_t idx : unit.indices) kit.indices.push_back(base + idx);
  }
  // By mass alone the smallest spheres get fewer than 12 vertices each.
  PipelineOptions by_mass = default_options(5000);
  by_mass.cvt.equal_part_share = 0;
  auto thin = run_pipeline(kit, by_mass);
  ASSERT_TRUE(thin.ok()) << thin.status().to_string();
  EXPECT_LT(per_sphere_counts(thin->mesh, spheres)[0], 12);

  auto result = run_pipeline(kit, default_options(5000));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  const Mesh& out = result->mesh;
  const MeshQuality q = mesh_quality(out);
  EXPECT_EQ(q.components, size_t(kParts));
  EXPECT_TRUE(q.closed) << q.boundary_edges << " boundary edges";
  EXPECT_EQ(q.non_manifold_edges, 0u);
  EXPECT_NEAR(double(out.vertex_count()), 5000.0, 100.0);

  // Every output vertex lies on the sphere nearest to it: between the
  // icosphere's inscribed faces and its vertices (0.9 r to 1.0 r), plus the
  // L2 fit's outward offset, at most max_offset_per_edge x the vertex's mean
  // edge length (measured here after the offset, so a little longer than the
  // fit saw: a looser bound, never a tighter one). And every sphere gets
  // enough vertices for a closed polyhedron that is not flat.
  std::vector<double> edge_sum(out.vertex_count(), 0.0), edges(out.vertex_count(), 0.0);
  for (size_t f = 0; f < out.face_count(); ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t a = out.indices[3 * f + c], b = out.indices[3 * f + (c + 1) % 3];
      double len2 = 0;
      for (int k = 0; k < 3; ++k) len2 += std::pow(double(out.positions[3 * a + k]) - out.positions[3 * b + k], 2);
      for (uint32_t x : {a, b}) edge_sum[x] += std::sqrt(len2), edges[x] += 1;
    }
  const double fit = OffsetFitOptions{}.max_offset_per_edge;
  for (size_t v = 0; v < out.vertex_count(); ++v) {
    const auto [best, d] = nearest_sphere(&out.positions[3 * v], spheres);
    ASSERT_GE(d, 0.9 * spheres[best][3]) << "vertex " << v << " inside sphere " << best;
    ASSERT_LE(d, 1.0 * spheres[best][3] + fit * edge_sum[v] / edges[v] + 1e-5)
        << "vertex " << v << " outside sphere " << best;
  }
  const std::vector<int> per_sphere = per_sphere_counts(out, spheres);
  for (int i = 0; i < kParts; ++i) EXPECT_GE(per_sphere[i], 12) << "sphere " << i << " (radius " << spheres[i][3] << ")";
}

// A target too small for every part's minimum (4 vertices, a tetrahedron)
// is said, in the result and in the sampling stage's note, not hidden: 40
// parts need 160 vertices, the job asks for 100.
TEST(Pipeline, SaysWhenTheTargetIsTooSmallForEveryPart) {
  const Mesh unit = testing::icosphere(1);
  Mesh kit;
  for (int i = 0; i < 40; ++i) {
    const uint32_t base = uint32_t(kit.vertex_count());
    for (size_t v = 0; v < unit.vertex_count(); ++v)
      for (int a = 0; a < 3; ++a) kit.positions.push_back(unit.positions[3 * v + a] + (a == 0 ? 3.0f * float(i) : 0.0f));
    for (uint32_t idx : unit.indices) kit.indices.push_back(base + idx);
  }
  auto result = run_pipeline(kit, default_options(kMinTargetVertices));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_EQ(result->cvt.parts, 40u);
  EXPECT_GT(result->cvt.parts_below_minimum, 0u);
  EXPECT_LE(result->cvt.parts_below_minimum, 40u);
  bool noted = false;
  for (const StageTiming& t : result->stages) noted |= t.note.find("target too small") != std::string::npos;
  EXPECT_TRUE(noted) << "no stage note says the target is too small";

  auto roomy = run_pipeline(kit, default_options(400));
  ASSERT_TRUE(roomy.ok()) << roomy.status().to_string();
  EXPECT_EQ(roomy->cvt.parts_below_minimum, 0u);
}

// Foliage: a sphere and ten small one-sided leaves. At 100 vertices each leaf
// gets its minimum of four cells, too few for the dual to have a triangle
// there; before the part fallback held open parts to their shape, every leaf
// vanished with its boundary loop (scripts/stress-shapes.py's
// sphere-with-30-leaves: 30 vertices came back for 150).
TEST(Pipeline, SmallOpenPartsKeepTheirLoopsAtALowCount) {
  Mesh scene = testing::icosphere(3);
  constexpr int kLeaves = 10, kGrid = 8;
  for (int k = 0; k < kLeaves; ++k) {
    const uint32_t base = uint32_t(scene.vertex_count());
    const float angle = 2.0f * 3.14159265f * float(k) / kLeaves;
    const float cx = 1.6f * std::cos(angle), cy = 1.6f * std::sin(angle), size = 0.12f;
    for (int j = 0; j <= kGrid; ++j)
      for (int i = 0; i <= kGrid; ++i) {
        const float x = size * float(i) / kGrid, y = size * float(j) / kGrid;
        scene.positions.insert(scene.positions.end(), {cx + x, cy + y, 0.2f * size * std::sin(20.0f * x)});
      }
    for (uint32_t j = 0; j < kGrid; ++j)
      for (uint32_t i = 0; i < kGrid; ++i) {
        const uint32_t a = base + j * (kGrid + 1) + i, b = a + 1, c = a + kGrid + 2, d = a + kGrid + 1;
        scene.indices.insert(scene.indices.end(), {a, b, c, a, c, d});
      }
  }
  auto result = run_pipeline(scene, default_options(100));
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_NEAR(double(result->mesh.vertex_count()), 100.0, 2.0);
  const MeshQuality q = mesh_quality(result->mesh);
  EXPECT_EQ(q.boundary_loops, size_t(kLeaves));
  EXPECT_EQ(q.sheets, size_t(kLeaves + 1));
  EXPECT_EQ(q.non_manifold_edges, 0u);
}

// --drop-parts-smaller-than leaves out only what the user names; by default
// a speck 1% of the model's size stays.
TEST(Pipeline, DropsSmallPartsOnlyWhenAsked) {
  Mesh kit = testing::icosphere(3);
  const Mesh speck = testing::icosphere(1, 0.01f);
  const uint32_t base = uint32_t(kit.vertex_count());
  for (size_t v = 0; v < speck.vertex_count(); ++v)
    for (int a = 0; a < 3; ++a) kit.positions.push_back(speck.positions[3 * v + a] + (a == 0 ? 2.0f : 0.0f));
  for (uint32_t idx : speck.indices) kit.indices.push_back(base + idx);

  auto kept = run_pipeline(kit, default_options(400));
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  EXPECT_EQ(mesh_quality(kept->mesh).components, 2u);
  EXPECT_EQ(kept->dropped_parts, 0u);

  PipelineOptions o = default_options(400);
  o.drop_parts_smaller_than = 0.02;  // the speck's diagonal is 0.035 / 3.5 = 1% of the model's
  auto dropped = run_pipeline(kit, o);
  ASSERT_TRUE(dropped.ok()) << dropped.status().to_string();
  EXPECT_EQ(mesh_quality(dropped->mesh).components, 1u);
  EXPECT_EQ(dropped->dropped_parts, 1u);
  EXPECT_EQ(dropped->ignored_vertices, speck.vertex_count());
  EXPECT_NEAR(double(dropped->mesh.vertex_count()), 400.0, 8.0);
  for (size_t v = 0; v < dropped->mesh.vertex_count(); ++v) ASSERT_LT(dropped->mesh.positions[3 * v], 1.5f);
}

TEST(Pipeline, StopsAtAStageBoundaryWhenCancelled) {
  const Mesh sphere = testing::icosphere(3);
  PipelineOptions o = default_options(500);
  std::atomic<int> boundaries{0};
  o.keep_going = [&] { return ++boundaries < 3; };
  auto r = run_pipeline(sphere, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kCancelled);
  EXPECT_EQ(boundaries.load(), 3);
}

TEST(Pipeline, FourteenViewsFindAtLeastAsManySaliencyPoints) {
  auto input = read_mesh("../shared/models/spot.obj");
  ASSERT_TRUE(input.ok()) << input.status().to_string();
  auto six = run_pipeline(*input, default_options(1000));
  PipelineOptions o = default_options(1000);
  o.views.count = 14;
  auto fourteen = run_pipeline(*input, o);
  ASSERT_TRUE(six.ok() && fourteen.ok());
  EXPECT_GT(fourteen->saliency_points, six->saliency_points);
}

}  // namespace
}  // namespace vpr
