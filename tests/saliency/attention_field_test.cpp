// The attention field (attention_field.h) on shapes whose answer we know: a
// small bump on a sphere stands out, the field spans [min_importance, 1] with
// few vertices at the top, the weighted means equal brute force, the front-top
// bias orders an otherwise uniform sphere, feature points near a region raise
// it (weighted counts equal brute force), and bad options are refused.
#include "saliency/attention_field.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../test_meshes.h"
#include "surface/surface_density.h"

namespace vpr {
namespace {

// Uniform floats in [0, 1) from a linear congruential generator: the same
// cloud on every machine.
struct Uniform {
  uint32_t state;
  float operator()() {
    state = state * 1664525u + 1013904223u;
    return float(state >> 8) / float(1u << 24);
  }
};

const ExecContext kCpu{};

// The field's curvature as the pipeline computes it (concave edges weighed by
// the options' concave_weight).
std::vector<float> curvature_of(const Mesh& mesh, const AttentionFieldOptions& options = {}) {
  std::vector<double> h;
  mean_curvatures(mesh, options.concave_weight, nullptr, &h);
  return std::vector<float>(h.begin(), h.end());
}

StatusOr<std::vector<float>> field_of(const Mesh& mesh, const AttentionFieldOptions& options = {}) {
  const std::vector<float> h = curvature_of(mesh, options);
  std::vector<float> field;
  VPR_RETURN_IF_ERROR(
      cpu::attention_field(mesh.positions.data(), h.data(), nullptr, {}, mesh.vertex_count(), options, &field, kCpu));
  return field;
}

// A unit icosphere (10,242 vertices) with a Gaussian bump of height `height`
// and angular radius `width` (radians) around the unit direction `axis`.
Mesh bumped_sphere(Vec3 axis, float height, float width) {
  Mesh m = testing::icosphere(5);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* p = &m.positions[3 * v];
    const float c = std::clamp(p[0] * axis.x + p[1] * axis.y + p[2] * axis.z, -1.0f, 1.0f);
    const float angle = std::acos(c);
    const float r = 1.0f + height * std::exp(-angle * angle / (2 * width * width));
    for (int k = 0; k < 3; ++k) p[k] *= r;
  }
  return m;
}

// Vertices within `angle` of the axis.
std::vector<size_t> cap_of(const Mesh& m, Vec3 axis, float angle) {
  std::vector<size_t> out;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const float* p = &m.positions[3 * v];
    const float len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    if ((p[0] * axis.x + p[1] * axis.y + p[2] * axis.z) / len >= std::cos(angle)) out.push_back(v);
  }
  return out;
}

float quantile(std::vector<float> v, double q) {
  std::sort(v.begin(), v.end());
  return v[size_t(q * double(v.size() - 1))];
}

double share_at_max(const std::vector<float>& f) {
  const float top = *std::max_element(f.begin(), f.end());
  return double(std::count_if(f.begin(), f.end(), [&](float x) { return x >= top - 1e-6f; })) / double(f.size());
}

// The bump's crest (the vertices within 5/8 of its width of the axis) must be
// in the field's top 5%. On the side (+x: halfway along the front-top
// direction) with the default bias, and anywhere with the bias off.
TEST(AttentionField, ASmallBumpOnASphereIsInTheTopFivePercent) {
  struct Case {
    Vec3 axis;
    float view_bias;
  };
  const float s = 1.0f / std::sqrt(3.0f);
  for (const Case& c :
       {Case{{1, 0, 0}, 0.75f}, Case{{0, 0, 1}, 0.75f}, Case{{-s, -s, -s}, 0.0f}, Case{{0, -1, 0}, 0.0f}}) {
    const Mesh m = bumped_sphere(c.axis, 0.03f, 0.08f);
    AttentionFieldOptions o;
    o.view_bias = c.view_bias;
    auto field = field_of(m, o);
    ASSERT_TRUE(field.ok()) << field.status().to_string();
    const float top5 = quantile(*field, 0.95);
    const std::vector<size_t> crest = cap_of(m, c.axis, 0.05f);
    ASSERT_GE(crest.size(), 5u);
    for (size_t v : crest)
      EXPECT_GE((*field)[v], top5) << "crest vertex " << v << " of the bump at (" << c.axis.x << ", " << c.axis.y
                                   << ", " << c.axis.z << "), bias " << c.view_bias;
  }
}

// Convexity: a bump draws the eye, a dimple of the same size does not (its
// floor is concave); with plain |H| (concave_weight 1) both stand out alike.
TEST(AttentionField, ABumpStandsOutAndADimpleOfTheSameSizeDoesNot) {
  Mesh m = bumped_sphere({1, 0, 0}, 0.03f, 0.08f);
  for (size_t v = 0; v < m.vertex_count(); ++v) {  // and a dimple on the opposite side
    float* p = &m.positions[3 * v];
    const float len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const float angle = std::acos(std::clamp(-p[0] / len, -1.0f, 1.0f));
    const float r = 1.0f - 0.03f * std::exp(-angle * angle / (2 * 0.08f * 0.08f));
    for (int k = 0; k < 3; ++k) p[k] *= r;
  }
  const std::vector<size_t> bump = cap_of(m, {1, 0, 0}, 0.05f), dimple = cap_of(m, {-1, 0, 0}, 0.05f);
  ASSERT_GE(bump.size(), 5u);
  ASSERT_GE(dimple.size(), 5u);
  for (float concave_weight : {0.0f, 1.0f}) {
    AttentionFieldOptions o;
    o.view_bias = 0;  // the two sides alike but for their shape
    o.concave_weight = concave_weight;
    auto field = field_of(m, o);
    ASSERT_TRUE(field.ok()) << field.status().to_string();
    const float top5 = quantile(*field, 0.95), median = quantile(*field, 0.5);
    for (size_t v : bump) EXPECT_GE((*field)[v], top5) << "bump vertex " << v << ", concave weight " << concave_weight;
    for (size_t v : dimple) {
      if (concave_weight == 0.0f)
        EXPECT_LT((*field)[v], median) << "dimple vertex " << v;
      else
        EXPECT_GE((*field)[v], top5) << "dimple vertex " << v << " with plain |H|";
    }
  }
}

// Range: the field spans [min_importance, 1] and few vertices share the top,
// on generated shapes from smooth to faceted (the paper's field put 50-90% of
// the vertices at 1).
TEST(AttentionField, SpansItsRangeWithFewVerticesAtTheMaximum) {
  std::vector<Mesh> shapes = {testing::icosphere(4), bumped_sphere({0, 1, 0}, 0.2f, 0.3f), testing::icosphere(1),
                              bumped_sphere({1, 0, 0}, -0.3f, 0.5f)};
  AttentionFieldOptions o;
  o.min_importance = 0.3f;
  for (size_t i = 0; i < shapes.size(); ++i) {
    auto field = field_of(shapes[i], o);
    ASSERT_TRUE(field.ok()) << field.status().to_string();
    ASSERT_EQ(field->size(), shapes[i].vertex_count());
    const auto [lo, hi] = std::minmax_element(field->begin(), field->end());
    // Equal values at either end share their mean rank (a dimple's concave
    // floor, no cue at all with concave_weight 0, is one such run: a few
    // vertices, so the bottom moves by a hair).
    EXPECT_GE(*lo, 0.3f - 1e-6f) << "shape " << i;
    EXPECT_LT(*lo, 0.31f) << "shape " << i;
    const float bottom = *lo;  // (a structured binding cannot be captured in C++17)
    EXPECT_LE(double(std::count_if(field->begin(), field->end(), [&](float x) { return x <= bottom + 1e-6f; })),
              0.05 * double(field->size()))
        << "shape " << i;
    EXPECT_LE(*hi, 1.0f + 1e-6f) << "shape " << i;
    EXPECT_GT(*hi, 0.999f) << "shape " << i;
    EXPECT_LE(share_at_max(*field), 0.05) << "shape " << i;
    // Rank normalization: the median sits in the middle of the range.
    EXPECT_NEAR(quantile(*field, 0.5), 0.65f, 0.05f) << "shape " << i;
  }
}

// The weighted means over the grid equal a brute-force sum over every vertex
// within 2 sigma, on a random cloud (several cells wide, one vertex near each
// corner of the grid).
TEST(AttentionField, GridMeansEqualBruteForce) {
  std::vector<float> p, h;
  Uniform next{12345};
  for (int i = 0; i < 3000; ++i) {
    p.insert(p.end(), {next(), 0.5f * next(), 0.25f * next()});
    h.push_back(next());
  }
  AttentionFieldOptions o;
  o.coarse_sigma = 0.05f;
  const size_t n = h.size();
  const VertexGrid grid = build_vertex_grid(p.data(), h.data(), n, o);
  size_t checked = 0;
  for (size_t v = 0; v < n; v += 7) {
    double sum = 0, weight = 0;
    for (size_t u = 0; u < n; ++u) {
      const float dx = p[3 * u] - p[3 * v], dy = p[3 * u + 1] - p[3 * v + 1], dz = p[3 * u + 2] - p[3 * v + 2];
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 > 4 * grid.sigma * grid.sigma) continue;
      const float t = 1.0f - d2 / (4 * grid.sigma * grid.sigma);
      const double w = double(t) * double(t);
      sum += w * h[u];
      weight += w;
    }
    const float got = coarse_curvature_mean(grid.sorted.data(), grid.cell_start.data(), grid.lo, grid.cell, grid.dims,
                                            p[3 * v], p[3 * v + 1], p[3 * v + 2], grid.sigma);
    EXPECT_NEAR(got, sum / weight, 1e-5) << "vertex " << v;
    ++checked;
  }
  EXPECT_GT(checked, 400u);
}

// The grid lists each cell's vertices in index order, cells in order, with
// their positions and curvature beside: the same grid on any thread count
// (it is binned in parallel), on 60,000 random vertices.
TEST(AttentionField, GridIsTheSameOnAnyThreadCount) {
  std::vector<float> p, h;
  Uniform next{99};
  for (int i = 0; i < 60000; ++i) {
    p.insert(p.end(), {next(), 0.5f * next(), 0.25f * next()});
    h.push_back(next());
  }
  AttentionFieldOptions o;
  o.coarse_sigma = 0.03f;
  const size_t n = h.size();
  VertexGrid one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = build_vertex_grid(p.data(), h.data(), n, o);
  }
  ASSERT_EQ(one.order.size(), n);
  ASSERT_EQ(one.cell_start.back(), n);
  const size_t cells = size_t(one.dims[0]) * one.dims[1] * one.dims[2];
  ASSERT_EQ(one.cell_start.size(), cells + 1);
  EXPECT_GT(cells, 100u);
  for (size_t c = 0; c < cells; ++c)
    for (uint32_t t = one.cell_start[c]; t < one.cell_start[c + 1]; ++t) {
      const uint32_t v = one.order[t];
      if (t > one.cell_start[c]) EXPECT_LT(one.order[t - 1], v) << "cell " << c;
      const int x = std::min(int((p[3 * v] - one.lo[0]) / one.cell), one.dims[0] - 1);
      EXPECT_EQ(size_t(x), c % size_t(one.dims[0])) << "vertex " << v;
      EXPECT_EQ(one.sorted[4 * t], p[3 * v]);
      EXPECT_EQ(one.sorted[4 * t + 3], h[v]);
    }
  for (int threads : {2, 4, 8}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    tbb::task_arena arena(threads);
    VertexGrid g;
    arena.execute([&] { g = build_vertex_grid(p.data(), h.data(), n, o); });
    EXPECT_EQ(g.order, one.order) << threads << " threads";
    EXPECT_EQ(g.cell_start, one.cell_start);
    EXPECT_EQ(g.sorted, one.sorted);
  }
}

// The weighted count of feature points near a vertex equals a brute-force sum,
// on a cloud of points partly outside the vertices' box (binned to its border
// cells).
TEST(AttentionField, FeaturePointDensityEqualsBruteForce) {
  std::vector<float> p, h(2000, 1.0f), q;
  Uniform next{777};
  for (size_t i = 0; i < h.size(); ++i) p.insert(p.end(), {next(), 0.5f * next(), 0.25f * next()});
  for (int i = 0; i < 5000; ++i) q.insert(q.end(), {1.1f * next() - 0.05f, 0.6f * next() - 0.05f, 0.25f * next()});
  AttentionFieldOptions o;
  o.coarse_sigma = 0.04f;
  const VertexGrid grid = build_vertex_grid(p.data(), h.data(), h.size(), o);
  const VertexGrid points = bin_points(grid, q.data(), q.size() / 3);
  ASSERT_EQ(points.cell_start.back(), q.size() / 3);
  size_t nonzero = 0;
  for (size_t v = 0; v < h.size(); v += 5) {
    double weight = 0;
    for (size_t u = 0; u < q.size() / 3; ++u) {
      const float dx = q[3 * u] - p[3 * v], dy = q[3 * u + 1] - p[3 * v + 1], dz = q[3 * u + 2] - p[3 * v + 2];
      const float d2 = dx * dx + dy * dy + dz * dz;
      if (d2 > 4 * grid.sigma * grid.sigma) continue;
      const float t = 1.0f - d2 / (4 * grid.sigma * grid.sigma);
      weight += double(t) * double(t);
    }
    const float got = feature_point_density(points.sorted.data(), points.cell_start.data(), points.lo, points.cell,
                                            points.dims, p[3 * v], p[3 * v + 1], p[3 * v + 2], points.sigma);
    EXPECT_NEAR(got, weight, 1e-4 * std::max(1.0, weight)) << "vertex " << v;
    nonzero += weight > 0;
  }
  EXPECT_GT(nonzero, 300u);
}

// The image cue: on a plain sphere (flat curvature, no bias) feature points
// scattered over one cap put that cap in the field's top 10%, and the field
// without the cue (no points, or image_cue off) leaves it near the middle.
TEST(AttentionField, FeaturePointsNearARegionRaiseIt) {
  const Mesh m = testing::icosphere(5);
  const std::vector<float> h = curvature_of(m);
  const Vec3 axis{-0.6f, 0.0f, 0.8f};
  const std::vector<size_t> cap = cap_of(m, axis, 0.25f);
  ASSERT_GE(cap.size(), 50u);
  // One point near each cap vertex, pushed 0.002 off the surface (unprojected
  // pixels are not exactly on it), plus a sparse scatter over the whole sphere.
  std::vector<float> points;
  for (size_t v : cap)
    for (int k = 0; k < 3; ++k) points.push_back(1.002f * m.positions[3 * v + k]);
  for (size_t v = 0; v < m.vertex_count(); v += 37)
    for (int k = 0; k < 3; ++k) points.push_back(m.positions[3 * v + k]);
  AttentionFieldOptions o;
  o.view_bias = 0;
  o.image_cue = true;
  const FeaturePoints features{points.data(), points.size() / 3};
  std::vector<float> with, without, off;
  ASSERT_TRUE(
      cpu::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o, &with, kCpu).ok());
  ASSERT_TRUE(
      cpu::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), o, &without, kCpu).ok());
  AttentionFieldOptions no_cue = o;
  no_cue.image_cue = false;
  ASSERT_TRUE(
      cpu::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), no_cue, &off, kCpu).ok());
  EXPECT_EQ(off, without);
  const std::vector<size_t> centre = cap_of(m, axis, 0.15f);
  const float top10 = quantile(with, 0.90);
  for (size_t v : centre) EXPECT_GE(with[v], top10) << "cap vertex " << v;
  double mean_without = 0;
  for (size_t v : centre) mean_without += without[v];
  EXPECT_LT(mean_without / double(centre.size()), 0.85);
  EXPECT_LE(share_at_max(with), 0.05);
  // Null points with a count are refused.
  EXPECT_EQ(cpu::attention_field(m.positions.data(), h.data(), nullptr, {nullptr, 3}, m.vertex_count(), o, &with, kCpu)
                .code(),
            StatusCode::kInvalidArgument);
}

// On a sphere the curvature cue is flat, so the bias alone orders it: the
// front-top cap outranks the back-bottom one, and with the bias off neither does.
TEST(AttentionField, FrontTopBiasOrdersAUniformSphere) {
  const Mesh m = testing::icosphere(4);
  const float s = 1.0f / std::sqrt(2.0f);
  const std::vector<size_t> front = cap_of(m, {0, s, s}, 0.3f), back = cap_of(m, {0, -s, -s}, 0.3f);
  auto mean_over = [](const std::vector<float>& f, const std::vector<size_t>& set) {
    double sum = 0;
    for (size_t v : set) sum += f[v];
    return sum / double(set.size());
  };
  auto biased = field_of(m);
  ASSERT_TRUE(biased.ok());
  EXPECT_GT(mean_over(*biased, front), 0.9);
  EXPECT_LT(mean_over(*biased, back), 0.4);
  AttentionFieldOptions off;
  off.view_bias = 0;
  auto flat = field_of(m, off);
  ASSERT_TRUE(flat.ok());
  EXPECT_LT(std::abs(mean_over(*flat, front) - mean_over(*flat, back)), 0.15);
}

// The grid and fine map made ahead (prepare_attention, as the pipeline does
// beside stages 1-3) give the field the twin gives making them itself, bit
// for bit, with and without the image cue; a bump makes the field uneven, so
// a mix-up of grids or maps would show.
TEST(AttentionField, PreparedGridAndMapGiveTheSameField) {
  const Mesh m = bumped_sphere({0.0f, 0.6f, 0.8f}, 0.08f, 0.25f);
  const std::vector<float> h = curvature_of(m);
  std::vector<float> points;
  for (size_t v = 0; v < m.vertex_count(); v += 7)
    points.insert(points.end(), &m.positions[3 * v], &m.positions[3 * v + 3]);
  AttentionFieldOptions with_cue;
  with_cue.image_cue = true;
  for (const AttentionFieldOptions& o : {AttentionFieldOptions{}, with_cue}) {
    const FeaturePoints features{points.data(), points.size() / 3};
    std::vector<float> own, given;
    ASSERT_TRUE(
        cpu::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o, &own, kCpu).ok());
    const AttentionPrep prep = prepare_attention(m.positions.data(), h.data(), m.vertex_count(), o);
    ASSERT_TRUE(
        cpu::attention_field(m.positions.data(), h.data(), nullptr, features, m.vertex_count(), o, &given, kCpu, &prep)
            .ok());
    EXPECT_EQ(given, own) << (o.image_cue ? "with" : "without") << " the image cue";
    const auto [lo, hi] = std::minmax_element(own.begin(), own.end());
    EXPECT_LT(*lo + 0.5f, *hi);  // an uneven field
  }
}

TEST(AttentionField, RefusesBadOptionsAndHandlesNoVertices) {
  const Mesh m = testing::icosphere(1);
  const std::vector<float> h = curvature_of(m);
  std::vector<float> field;
  AttentionFieldOptions bad;
  bad.coarse_sigma = 0;
  EXPECT_EQ(cpu::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), bad, &field, kCpu).code(),
            StatusCode::kInvalidArgument);
  bad = {};
  bad.view_bias = 1.5f;
  EXPECT_EQ(cpu::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), bad, &field, kCpu).code(),
            StatusCode::kInvalidArgument);
  bad = {};
  bad.concave_weight = -0.5f;
  const Status concave = cpu::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), bad, &field, kCpu);
  EXPECT_EQ(concave.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(concave.message().find("concave_weight"), std::string::npos) << concave.message();
  bad = {};
  bad.min_importance = 0;
  EXPECT_EQ(cpu::attention_field(m.positions.data(), h.data(), nullptr, {}, m.vertex_count(), bad, &field, kCpu).code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::attention_field(m.positions.data(), nullptr, nullptr, {}, m.vertex_count(), {}, &field, kCpu).code(),
            StatusCode::kInvalidArgument);
  field.assign(3, 1.0f);
  EXPECT_TRUE(cpu::attention_field(nullptr, nullptr, nullptr, {}, 0, {}, &field, kCpu).ok());
  EXPECT_TRUE(field.empty());
}

}  // namespace
}  // namespace vpr
