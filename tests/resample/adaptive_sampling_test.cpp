// Stage 5 (Eq. 7-16): inverse CDFs against their equations, exact sample
// counts against the sequential error diffusion, and the sample distribution
// against the interpolated importance by a chi-square test.
#include "resample/adaptive_sampling.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace vpr {
namespace {

const ExecContext kCpu{};

double marginal_g(double s, double ia, double ib, double ic) {
  return ia * (s * s / 2 - s * s * s / 3) + (ib + ic) / 2 * s * s * s / 3;
}

TEST(InverseCdf, SSolvesTheCubicAndIsMonotone) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::array<double, 3>> cases = {{1, 0.2, 0.6},   {0.2, 1, 1},  {1, 0, 0},      {0, 1, 0},
                                              {0.5, 0.5, 0.5}, {1e-6, 1, 1}, {1, 1e-6, 1e-6}};
  for (int i = 0; i < 50; ++i) cases.push_back({u(rng), u(rng), u(rng)});
  double worst = 0.0;
  for (const auto& c : cases) {
    const double total = marginal_g(1.0, c[0], c[1], c[2]);
    float prev = 0.0f;
    for (int i = 0; i <= 4000; ++i) {
      const double r = i / 4000.0;
      const double s = adaptive_s_d(r, c[0], c[1], c[2]);
      ASSERT_GE(s, 0.0);
      ASSERT_LE(s, 1.0);
      worst = std::max(worst, std::abs(marginal_g(s, c[0], c[1], c[2]) - r * total) / total);
      const float sf = adaptive_s(float(r), float(c[0]), float(c[1]), float(c[2]));
      ASSERT_GE(sf, prev) << "r = " << r;  // monotone in r
      prev = sf;
    }
    EXPECT_EQ(adaptive_s(0.0f, c[0], c[1], c[2]), 0.0f);
    EXPECT_EQ(adaptive_s(1.0f, c[0], c[1], c[2]), 1.0f);
  }
  EXPECT_LT(worst, 1e-14);
  // Equal importances: the density is the uniform one, s = sqrt(r).
  for (double r : {0.01, 0.3, 0.77, 0.999}) EXPECT_NEAR(adaptive_s_d(r, 0.4, 0.4, 0.4), std::sqrt(r), 1e-15);
}

TEST(InverseCdf, TSolvesTheQuadraticIncludingTheLinearCase) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const double r = u(rng), s = u(rng), ia = u(rng), ib = u(rng), ic = u(rng);
    const double t = adaptive_t_d(r, s, ia, ib, ic);
    const double a = (1 - s) * ia + s * ib, b = s * (ic - ib);
    const double h1 = a + b / 2;
    ASSERT_GE(t, 0.0);
    ASSERT_LE(t, 1.0);
    worst = std::max(worst, std::abs(a * t + b * t * t / 2 - r * h1) / h1);
  }
  EXPECT_LT(worst, 1e-14);
  // I_b == I_c: the slice density is constant, t = r.
  EXPECT_NEAR(adaptive_t_d(0.37, 0.8, 1.0, 0.3, 0.3), 0.37, 1e-16);
  // s = 0: the slice is the point A, t = r.
  EXPECT_NEAR(adaptive_t_d(0.37, 0.0, 1.0, 0.2, 0.9), 0.37, 1e-16);
  // I_a = I_b = 0: density proportional to t, t = sqrt(r).
  EXPECT_NEAR(adaptive_t_d(0.25, 0.5, 0.0, 0.0, 1.0), 0.5, 1e-15);
  // Density proportional to 1 - t (I_c = 0): H(t) = t - t^2/2 = r/2.
  EXPECT_NEAR(adaptive_t_d(0.75, 1.0, 0.0, 1.0, 0.0), 1.0 - std::sqrt(0.25), 1e-15);
  EXPECT_EQ(adaptive_t(0.0f, 0.5f, 1.0f, 0.2f, 0.6f), 0.0f);
  EXPECT_EQ(adaptive_t(1.0f, 0.5f, 1.0f, 0.2f, 0.6f), 1.0f);
}

Mesh one_triangle() {
  Mesh m;
  // A general triangle off the axes, so (s, t) is recovered from barycentrics.
  m.positions = {0.3f, -0.2f, 0.1f, 1.4f, 0.1f, -0.3f, 0.2f, 0.9f, 0.6f};
  m.indices = {0, 1, 2};
  return m;
}

// Barycentric coordinates of p in face f (least squares in double).
std::array<double, 3> barycentric(const Mesh& m, size_t f, const float* p) {
  const Vec3d a = load3d(m.positions.data(), m.indices[3 * f]);
  const Vec3d b = load3d(m.positions.data(), m.indices[3 * f + 1]);
  const Vec3d c = load3d(m.positions.data(), m.indices[3 * f + 2]);
  const Vec3d e1 = b - a, e2 = c - a, d = Vec3d{p[0], p[1], p[2]} - a;
  const double g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2), r1 = dot(d, e1), r2 = dot(d, e2);
  const double det = g11 * g22 - g12 * g12;
  const double wb = (g22 * r1 - g12 * r2) / det, wc = (g11 * r2 - g12 * r1) / det;
  return {1.0 - wb - wc, wb, wc};
}

// Upper regularised incomplete gamma Q(a, x) (Numerical Recipes 6.2): the
// chi-square p-value is Q(dof / 2, chi2 / 2).
double gamma_q(double a, double x) {
  const double gln = std::lgamma(a);
  if (x < a + 1.0) {
    double sum = 1.0 / a, del = sum, ap = a;
    for (int n = 0; n < 1000; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * 1e-15) break;
    }
    return 1.0 - sum * std::exp(-x + a * std::log(x) - gln);
  }
  double b = x + 1.0 - a, c = 1e300, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - gln) * h;
}

struct ChiSquare {
  double statistic;
  double p_value;
};

// Histogram of the samples on a 10 x 10 grid of (s, t) cells against the
// density s [(1 - s) I_a + s (1 - t) I_b + s t I_c] integrated over each cell by
// 3 x 3 Gauss-Legendre quadrature (exact: the density is cubic in s, linear in t).
ChiSquare chi_square(const Mesh& m, const std::vector<float>& points, std::array<double, 3> density) {
  const int cells = 10;
  std::vector<double> observed(cells * cells, 0.0), expected(cells * cells, 0.0);
  const size_t n = points.size() / 3;
  for (size_t i = 0; i < n; ++i) {
    const std::array<double, 3> w = barycentric(m, 0, &points[3 * i]);
    const double s = 1.0 - w[0], t = s > 0 ? w[2] / s : 0.0;
    const int cs = std::clamp(int(s * cells), 0, cells - 1), ct = std::clamp(int(t * cells), 0, cells - 1);
    observed[cs * cells + ct] += 1;
  }
  const double node[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, weight[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  double total = 0.0;
  for (int cs = 0; cs < cells; ++cs)
    for (int ct = 0; ct < cells; ++ct) {
      double sum = 0.0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const double s = (cs + 0.5 + 0.5 * node[i]) / cells, t = (ct + 0.5 + 0.5 * node[j]) / cells;
          sum += weight[i] * weight[j] * s * ((1 - s) * density[0] + s * (1 - t) * density[1] + s * t * density[2]);
        }
      expected[cs * cells + ct] = sum;
      total += sum;
    }
  double chi2 = 0.0;
  for (int c = 0; c < cells * cells; ++c) {
    const double e = expected[c] / total * double(n);
    chi2 += (observed[c] - e) * (observed[c] - e) / e;
  }
  return {chi2, gamma_q((cells * cells - 1) / 2.0, chi2 / 2.0)};
}

std::vector<float> sample_one_triangle(const Mesh& m, const std::vector<float>& importance, uint32_t count,
                                       SamplingOptions options) {
  const uint32_t counts[1] = {count}, offsets[2] = {0, count};
  std::vector<float> points, point_importance;
  EXPECT_TRUE(
      cpu::sample_triangles(m, importance.data(), counts, offsets, options, &points, &point_importance, kCpu).ok());
  return points;
}

TEST(SampleTriangles, AdaptiveSamplesFollowTheInterpolatedImportance) {
  const Mesh m = one_triangle();
  const std::vector<float> importance = {1.0f, 0.2f, 0.6f};
  const std::vector<float> points = sample_one_triangle(m, importance, 200000, {});
  const ChiSquare fit = chi_square(m, points, {1.0, 0.2, 0.6});
  // 99 degrees of freedom; the 0.001 critical value is 148.2.
  std::printf("adaptive (1, 0.2, 0.6), 200k samples: chi2 = %.1f (99 dof), p = %.3f\n", fit.statistic, fit.p_value);
  EXPECT_GT(fit.p_value, 0.001) << "chi2 = " << fit.statistic;
  // The test has power: the same samples are far from uniform.
  const ChiSquare vs_uniform = chi_square(m, points, {1.0, 1.0, 1.0});
  std::printf("  same samples against the uniform density: chi2 = %.0f\n", vs_uniform.statistic);
  EXPECT_LT(vs_uniform.p_value, 1e-12);
}

TEST(SampleTriangles, UniformSamplesAreUniformInArea) {
  const Mesh m = one_triangle();
  // Below adaptive_min_samples the importances are ignored.
  SamplingOptions uniform;
  uniform.adaptive_min_samples = 1000000;
  const std::vector<float> points = sample_one_triangle(m, {1.0f, 0.2f, 0.6f}, 200000, uniform);
  const ChiSquare fit = chi_square(m, points, {1, 1, 1});
  std::printf("uniform sampler, 200k samples: chi2 = %.1f (99 dof), p = %.3f\n", fit.statistic, fit.p_value);
  EXPECT_GT(fit.p_value, 0.001) << "chi2 = " << fit.statistic;
  // The adaptive sampler with equal importances draws the same distribution
  // (another seed: with the same one it would redraw the very same points).
  SamplingOptions other_seed;
  other_seed.seed = 2;
  const std::vector<float> equal = sample_one_triangle(m, {0.5f, 0.5f, 0.5f}, 200000, other_seed);
  const ChiSquare fit_equal = chi_square(m, equal, {1, 1, 1});
  std::printf("adaptive sampler, equal importances: chi2 = %.1f, p = %.3f\n", fit_equal.statistic, fit_equal.p_value);
  EXPECT_GT(fit_equal.p_value, 0.001) << "chi2 = " << fit_equal.statistic;
}

TEST(VisualQuantity, IsAreaTimesMeanImportance) {
  Mesh m;
  m.positions = {0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 5, 1, 1, 1};
  m.indices = {0, 1, 2, 0, 1, 3, 4, 4, 0};  // areas 3, 5 and a degenerate face
  const std::vector<float> imp = {1.0f, 0.2f, 0.6f, 0.4f, 0.9f};
  std::vector<double> q;
  ASSERT_TRUE(cpu::visual_quantity(m, imp.data(), &q, kCpu).ok());
  ASSERT_EQ(q.size(), 3u);
  EXPECT_NEAR(q[0], 3.0 * (1.0 + 0.2 + 0.6) / 3, 1e-7);
  EXPECT_NEAR(q[1], 5.0 * (1.0 + 0.2 + 0.4) / 3, 1e-7);
  EXPECT_EQ(q[2], 0.0);
  std::vector<float> bad = imp;
  bad[3] = NAN;
  EXPECT_EQ(cpu::visual_quantity(m, bad.data(), &q, kCpu).code(), StatusCode::kInvalidArgument);
  bad[3] = -0.1f;
  EXPECT_EQ(cpu::visual_quantity(m, bad.data(), &q, kCpu).code(), StatusCode::kInvalidArgument);
}

// The sequential error diffusion of Eq. (9) on the fixed-point quantities of
// sampling_kernels.h, carrying the error itself as an exact integer remainder
// (denominator 2T): a different computation from the closed form
// round(target P_i / T), with the same answer when that is exact.
std::vector<uint32_t> error_diffusion(const std::vector<double>& q, uint32_t target) {
  const double q_max = *std::max_element(q.begin(), q.end());
  std::vector<uint64_t> fixed(q.size());
  QuantitySum total = 0;
  for (size_t i = 0; i < q.size(); ++i) total += fixed[i] = quantize_quantity(q[i], q_max);
  const QuantitySum denominator = 2 * total;
  QuantitySum remainder = total;  // the + 1/2 of round()
  std::vector<uint32_t> counts(q.size());
  for (size_t i = 0; i < q.size(); ++i) {
    const QuantitySum carried = remainder + QuantitySum(fixed[i]) * (2u * uint64_t(target));
    counts[i] = uint32_t(carried / denominator);
    remainder = carried % denominator;
  }
  return counts;
}

// The textbook form: carry the fractional error itself.
std::vector<uint32_t> carried_error(const std::vector<double>& q, uint32_t target) {
  double total = 0.0;
  for (double x : q) total += x;
  std::vector<uint32_t> counts(q.size());
  double error = 0.0;
  for (size_t i = 0; i < q.size(); ++i) {
    const double x = q[i] * target / total + error;
    const double n = std::max(0.0, std::floor(x + 0.5));
    counts[i] = uint32_t(n);
    error = x - n;
  }
  return counts;
}

TEST(DistributeCounts, SumsExactlyAndEqualsErrorDiffusion) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const size_t faces = 50000;
  std::vector<double> q(faces);
  for (double& x : q) {
    const double r = u(rng);
    // Magnitudes over six decades and some zero (degenerate) faces.
    x = r < 0.05 ? 0.0 : std::pow(10.0, -6.0 * u(rng)) * u(rng);
  }
  double total = 0.0;
  for (double x : q) total += x;
  for (uint32_t target : {1u, 7u, 10000u, 99991u, 4000000u}) {
    std::vector<uint32_t> counts, offsets;
    ASSERT_TRUE(cpu::distribute_counts(q.data(), faces, target, &counts, &offsets, kCpu).ok());
    ASSERT_EQ(counts.size(), faces);
    ASSERT_EQ(offsets.size(), faces + 1);
    uint64_t sum = 0;
    for (uint32_t c : counts) sum += c;
    EXPECT_EQ(sum, target);
    EXPECT_EQ(offsets[0], 0u);
    EXPECT_EQ(offsets[faces], target);
    EXPECT_EQ(counts, error_diffusion(q, target)) << "target " << target;
    // The emitted total never drifts more than 1/2 from the ideal.
    double acc = 0.0, drift = 0.0;
    size_t textbook_diffs = 0;
    const std::vector<uint32_t> textbook = carried_error(q, target);
    uint64_t textbook_prefix = 0;
    for (size_t i = 0; i < faces; ++i) {
      ASSERT_EQ(offsets[i + 1], offsets[i] + counts[i]);
      if (q[i] == 0.0) {
        ASSERT_EQ(counts[i], 0u) << "face " << i;
      }
      acc += q[i];
      drift = std::max(drift, std::abs(double(offsets[i + 1]) - double(target) * acc / total));
      textbook_prefix += textbook[i];
      ASSERT_LE(std::abs(double(textbook_prefix) - double(offsets[i + 1])), 1.0);
      textbook_diffs += textbook[i] != counts[i];
    }
    // 1/2, plus the fixed point's shift of at most F 2^-53 target.
    EXPECT_LE(drift, 0.5 + double(faces) * double(target) * 0x1p-53 + 1e-9);
    std::printf("target %u: max drift %.6f, faces differing from the carried-error loop: %zu\n", target, drift,
                textbook_diffs);
  }
}

TEST(DistributeCounts, UniformImportanceGivesCountsProportionalToArea) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Mesh m;
  for (int i = 0; i < 3 * 3000; ++i) m.positions.insert(m.positions.end(), {u(rng), u(rng), u(rng)});
  for (uint32_t i = 0; i < 3 * 3000; ++i) m.indices.push_back(i);
  const std::vector<float> ones(m.vertex_count(), 1.0f);
  std::vector<double> q;
  ASSERT_TRUE(cpu::visual_quantity(m, ones.data(), &q, kCpu).ok());
  const std::vector<double> area = face_areas(m);
  const double total = total_area(m);
  std::vector<uint32_t> counts, offsets;
  ASSERT_TRUE(cpu::distribute_counts(q.data(), q.size(), 20000, &counts, &offsets, kCpu).ok());
  double worst = 0.0;
  for (size_t f = 0; f < counts.size(); ++f) worst = std::max(worst, std::abs(counts[f] - 20000 * area[f] / total));
  EXPECT_LT(worst, 1.0);
}

TEST(DistributeCounts, RejectsZeroAndBadQuantities) {
  std::vector<uint32_t> counts, offsets;
  const std::vector<double> zeros(5, 0.0);
  const Status s = cpu::distribute_counts(zeros.data(), 5, 100, &counts, &offsets, kCpu);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("zero visual quantity"), std::string::npos) << s.message();
  for (double bad : {-1.0, double(NAN), double(INFINITY)}) {
    const std::vector<double> q = {1.0, bad, 2.0};
    EXPECT_EQ(cpu::distribute_counts(q.data(), 3, 10, &counts, &offsets, kCpu).code(), StatusCode::kInvalidArgument)
        << bad;
  }
  const std::vector<double> q = {1.0, 2.0};
  ASSERT_TRUE(cpu::distribute_counts(q.data(), 2, 0, &counts, &offsets, kCpu).ok());
  EXPECT_EQ(counts, (std::vector<uint32_t>{0, 0}));
}

// A soup of random, well-shaped triangles with random importances; 40k samples
// put some faces below adaptive_min_samples and some above.
struct Soup {
  Mesh mesh;
  std::vector<float> importance;
  std::vector<uint32_t> counts, offsets;
};

Soup random_soup() {
  Soup s;
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), imp(0.2f, 1.0f), size(0.01f, 0.3f);
  for (uint32_t f = 0; f < 4000; ++f) {
    const float cx = u(rng), cy = u(rng), cz = u(rng), h = size(rng);
    for (int c = 0; c < 3; ++c) {
      s.mesh.positions.insert(s.mesh.positions.end(), {cx + h * u(rng), cy + h * u(rng), cz + h * u(rng)});
      s.mesh.indices.push_back(3 * f + c);
      s.importance.push_back(imp(rng));
    }
  }
  std::vector<double> q;
  EXPECT_TRUE(cpu::visual_quantity(s.mesh, s.importance.data(), &q, kCpu).ok());
  EXPECT_TRUE(cpu::distribute_counts(q.data(), q.size(), 40000, &s.counts, &s.offsets, kCpu).ok());
  return s;
}

TEST(SampleTriangles, SamplesLieInTheirFaceWithInterpolatedImportance) {
  const Soup s = random_soup();
  size_t uniform_faces = 0, adaptive_faces = 0;
  for (uint32_t c : s.counts) (c < 5 ? uniform_faces : adaptive_faces) += c > 0;
  EXPECT_GT(uniform_faces, 500u);
  EXPECT_GT(adaptive_faces, 500u);
  std::vector<float> points, pi;
  ASSERT_TRUE(
      cpu::sample_triangles(s.mesh, s.importance.data(), s.counts.data(), s.offsets.data(), {}, &points, &pi, kCpu)
          .ok());
  ASSERT_EQ(points.size(), 3u * 40000);
  double lowest = 1.0, worst_importance = 0.0;
  for (size_t f = 0; f < s.counts.size(); ++f)
    for (uint32_t j = 0; j < s.counts[f]; ++j) {
      const size_t i = s.offsets[f] + j;
      const std::array<double, 3> w = barycentric(s.mesh, f, &points[3 * i]);
      lowest = std::min({lowest, w[0], w[1], w[2]});
      const double interpolated =
          w[0] * s.importance[3 * f] + w[1] * s.importance[3 * f + 1] + w[2] * s.importance[3 * f + 2];
      worst_importance = std::max(worst_importance, std::abs(interpolated - pi[i]));
    }
  EXPECT_GE(lowest, -1e-6);
  EXPECT_LT(worst_importance, 1e-5);
}

TEST(SampleTriangles, RejectsInconsistentOffsets) {
  const Soup s = random_soup();
  std::vector<uint32_t> offsets = s.offsets;
  offsets[7] += 1;
  std::vector<float> points, pi;
  EXPECT_EQ(cpu::sample_triangles(s.mesh, s.importance.data(), s.counts.data(), offsets.data(), {}, &points, &pi, kCpu)
                .code(),
            StatusCode::kInvalidArgument);
}

// Igea (binary little-endian PLY: float x y z, then uchar 3 + 3 int per face).
Mesh load_igea() {
  std::ifstream in("../shared/models/igea.ply", std::ios::binary);
  if (!in) return {};
  std::string line;
  size_t nv = 0, nf = 0;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) nv = std::stoul(line.substr(15));
    if (line.rfind("element face ", 0) == 0) nf = std::stoul(line.substr(13));
  }
  Mesh m;
  m.positions.resize(3 * nv);
  in.read(reinterpret_cast<char*>(m.positions.data()), std::streamsize(m.positions.size() * sizeof(float)));
  m.indices.resize(3 * nf);
  for (size_t f = 0; f < nf && in; ++f) {
    unsigned char corners = 0;
    int32_t idx[3];
    in.read(reinterpret_cast<char*>(&corners), 1);
    if (corners != 3) return {};
    in.read(reinterpret_cast<char*>(idx), sizeof(idx));
    for (int c = 0; c < 3; ++c) m.indices[3 * f + c] = uint32_t(idx[c]);
  }
  return in ? m : Mesh{};
}

// Igea's 268,686 triangles to 10,000 samples; importance ramps from 0.2 at the
// bottom to 1 at the top. Same seed: identical at 1 and 2 threads; other seed:
// other points.
TEST(SampleTriangles, IgeaIsDeterministicAcrossThreadsAndSeeds) {
  const Mesh m = load_igea();
  if (m.positions.empty()) GTEST_SKIP() << "../shared/models/igea.ply not found";
  ASSERT_EQ(m.face_count(), 268686u);
  const Aabb box = bounding_box(m);
  std::vector<float> importance(m.vertex_count());
  for (size_t v = 0; v < m.vertex_count(); ++v)
    importance[v] = 0.2f + 0.8f * (m.positions[3 * v + 1] - box.lo[1]) / (box.hi[1] - box.lo[1]);

  auto run = [&](int threads, uint64_t seed, double* seconds, std::vector<float>* pi) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<double> q;
    std::vector<uint32_t> counts, offsets;
    std::vector<float> points;
    EXPECT_TRUE(cpu::visual_quantity(m, importance.data(), &q, kCpu).ok());
    EXPECT_TRUE(cpu::distribute_counts(q.data(), q.size(), 10000, &counts, &offsets, kCpu).ok());
    SamplingOptions o;
    o.seed = seed;
    EXPECT_TRUE(cpu::sample_triangles(m, importance.data(), counts.data(), offsets.data(), o, &points, pi, kCpu).ok());
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return points;
  };
  double t2 = 0, t1 = 0, t_other = 0;
  std::vector<float> pi2, pi1, pi_other;
  const std::vector<float> two = run(2, 1, &t2, &pi2);
  const std::vector<float> one = run(1, 1, &t1, &pi1);
  const std::vector<float> other = run(2, 2, &t_other, &pi_other);
  ASSERT_EQ(two.size(), 3u * 10000);
  EXPECT_EQ(one, two);
  EXPECT_EQ(pi1, pi2);
  size_t same = 0;
  for (size_t i = 0; i < 10000; ++i)
    same += two[3 * i] == other[3 * i] && two[3 * i + 1] == other[3 * i + 1] && two[3 * i + 2] == other[3 * i + 2];
  EXPECT_EQ(same, 0u);
  // Samples concentrate where importance is high: the mean importance of the
  // samples exceeds the area-weighted mean of the surface.
  double sample_mean = 0.0;
  for (float x : pi2) sample_mean += x;
  sample_mean /= 10000;
  const std::vector<double> area = face_areas(m);
  double surface_mean = 0.0, total = 0.0;
  for (size_t f = 0; f < area.size(); ++f) {
    surface_mean +=
        area[f] * (importance[m.indices[3 * f]] + importance[m.indices[3 * f + 1]] + importance[m.indices[3 * f + 2]]) /
        3;
    total += area[f];
  }
  surface_mean /= total;
  EXPECT_GT(sample_mean, surface_mean + 0.02);
  std::printf(
      "igea 268686 faces -> 10000 samples: %.4f s at 2 threads, %.4f s at 1; mean I of samples %.3f vs "
      "surface %.3f\n",
      t2, t1, sample_mean, surface_mean);
}

}  // namespace
}  // namespace vpr
