// SSIM against values computed by hand from its definition, and the rendered
// visual similarity of meshes whose ranking we know.
#include "eval/visual_similarity.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_meshes.h"

namespace vpr {
namespace {

constexpr double kC1 = (0.01 * 255) * (0.01 * 255);  // 6.5025
constexpr double kC2 = (0.03 * 255) * (0.03 * 255);  // 58.5225

FloatImage constant(int size, float value) {
  return FloatImage(size, size, value);
}

// a(x, y) = 100 + 20 (x - 5) on an 11x11 image: one window, whose Gaussian
// weighted mean is exactly 100 (the weights are symmetric about x = 5).
FloatImage ramp(float offset = 0, float sign = 1) {
  FloatImage img(11, 11);
  for (int y = 0; y < 11; ++y)
    for (int x = 0; x < 11; ++x) img.at(x, y) = offset + 100 + sign * 20.f * float(x - 5);
  return img;
}

// Sum over the 1D window of w(x) (x - 5)^2, w the normalised sigma 1.5 Gaussian.
double ramp_variance() {
  double sum = 0, second = 0;
  for (int x = 0; x < 11; ++x) {
    const double w = std::exp(-(x - 5) * (x - 5) / (2 * 1.5 * 1.5));
    sum += w;
    second += w * (x - 5) * (x - 5);
  }
  return 400 * second / sum;
}

TEST(Ssim, IdenticalImagesGiveOne) {
  FloatImage a = ramp();
  auto s = ssim(a, a);
  ASSERT_TRUE(s.ok());
  EXPECT_DOUBLE_EQ(*s, 1.0);
}

TEST(Ssim, ConstantImagesLuminanceOnly) {
  // sigma = 0 in both: SSIM = (2 mu_a mu_b + C1) / (mu_a^2 + mu_b^2 + C1).
  auto s = ssim(constant(11, 100), constant(11, 110));
  ASSERT_TRUE(s.ok());
  EXPECT_NEAR(*s, (2 * 100 * 110 + kC1) / (100.0 * 100 + 110.0 * 110 + kC1), 1e-12);  // 0.995481...
  EXPECT_NEAR(*s, 0.99548, 1e-5);
  // The same on a larger image: every valid window is the same.
  auto big = ssim(constant(32, 100), constant(32, 110));
  ASSERT_TRUE(big.ok());
  EXPECT_NEAR(*big, *s, 1e-12);
}

TEST(Ssim, ShiftedRampKeepsStructureLosesLuminance) {
  // b = a + 30: equal variances and covariance, so only the luminance term is left.
  auto s = ssim(ramp(), ramp(30));
  ASSERT_TRUE(s.ok());
  EXPECT_NEAR(*s, (2 * 100.0 * 130 + kC1) / (100.0 * 100 + 130.0 * 130 + kC1), 1e-9);
}

TEST(Ssim, InvertedRampIsAnticorrelated) {
  // b = 200 - a: same mean 100, covariance -var: SSIM = (C2 - 2 var) / (2 var + C2).
  const double var = ramp_variance();
  auto s = ssim(ramp(), ramp(0, -1));
  ASSERT_TRUE(s.ok());
  EXPECT_NEAR(*s, (kC2 - 2 * var) / (2 * var + kC2), 1e-9);
  EXPECT_LT(*s, -0.9);
}

TEST(Ssim, CentreMaskSelectsWindows) {
  // Left half equal, right half different: the mask picks the equal windows.
  FloatImage a = constant(40, 50), b = constant(40, 50);
  for (int y = 0; y < 40; ++y)
    for (int x = 20; x < 40; ++x) b.at(x, y) = 200;
  Mask left(40, 40, 0);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 14; ++x) left.at(x, y) = 1;  // windows reach x + 5 < 20
  auto masked = ssim(a, b, {}, &left);
  ASSERT_TRUE(masked.ok());
  EXPECT_DOUBLE_EQ(*masked, 1.0);
  auto whole = ssim(a, b);
  ASSERT_TRUE(whole.ok());
  EXPECT_LT(*whole, 0.8);
}

TEST(Ssim, RejectsBadInput) {
  EXPECT_FALSE(ssim(constant(11, 0), constant(12, 0)).ok());
  EXPECT_FALSE(ssim(constant(10, 0), constant(10, 0)).ok());
  SsimOptions even;
  even.window = 10;
  EXPECT_FALSE(ssim(constant(20, 0), constant(20, 0), even).ok());
  Mask none(20, 20, 0);
  auto s = ssim(constant(20, 0), constant(20, 0), {}, &none);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), StatusCode::kInvalidArgument);
}

// Rendering tests: one renderer for all (EGL or OSMesa, software is fine).
class VisualSimilarityTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto r = create_renderer(RendererKind::kAuto);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    renderer_ = std::move(*r).release();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  static VisualSimilarityOptions small() {
    VisualSimilarityOptions o;
    o.resolution = 128;
    return o;
  }
  static Renderer* renderer_;
};
Renderer* VisualSimilarityTest::renderer_ = nullptr;

TEST_F(VisualSimilarityTest, IdenticalMeshesGiveOne) {
  const Mesh sphere = testing::icosphere(4);
  auto ref = VisualReference::create(sphere, renderer_, small());
  ASSERT_TRUE(ref.ok()) << ref.status().to_string();
  ASSERT_EQ(ref->views().size(), 14u);
  auto v = ref->compare(sphere);
  ASSERT_TRUE(v.ok()) << v.status().to_string();
  EXPECT_NEAR(v->ssim_mean, 1.0, 1e-6);
  EXPECT_NEAR(v->ssim_worst, 1.0, 1e-6);
  EXPECT_NEAR(v->line_mean, 1.0, 1e-6);
  EXPECT_EQ(v->per_view.size(), 14u);
}

TEST_F(VisualSimilarityTest, DentLowersAndTranslationLowersMuchMore) {
  const Mesh sphere = testing::icosphere(4);
  // Dent: push the vertices within 0.35 of the +x pole inwards by up to 0.2.
  Mesh dented = sphere;
  for (size_t v = 0; v < dented.vertex_count(); ++v) {
    float* p = &dented.positions[3 * v];
    const float d = std::sqrt((p[0] - 1) * (p[0] - 1) + p[1] * p[1] + p[2] * p[2]);
    if (d < 0.35f) {
      const float s = 1 - 0.2f * (1 - d / 0.35f);
      for (int k = 0; k < 3; ++k) p[k] *= s;
    }
  }
  Mesh moved = sphere;  // a quarter of the radius sideways
  for (size_t v = 0; v < moved.vertex_count(); ++v) moved.positions[3 * v + 1] += 0.25f;

  auto ref = VisualReference::create(sphere, renderer_, small());
  ASSERT_TRUE(ref.ok());
  auto dent = ref->compare(dented);
  auto shift = ref->compare(moved);
  ASSERT_TRUE(dent.ok() && shift.ok());
  EXPECT_LT(dent->ssim_mean, 0.999);
  EXPECT_LT(dent->ssim_worst, dent->ssim_mean);  // the views facing the dent suffer most
  EXPECT_LT(dent->line_worst, 1.0);
  EXPECT_LT(shift->ssim_mean, dent->ssim_mean - 0.1);
  EXPECT_LT(shift->line_mean, dent->line_mean - 0.1);
  EXPECT_GT(shift->ssim_mean, -1.0);
}

TEST_F(VisualSimilarityTest, OneCallMatchesTheReferenceObject) {
  const Mesh a = testing::icosphere(3), b = testing::icosphere(2);
  auto once = visual_similarity(a, b, small());
  ASSERT_TRUE(once.ok()) << once.status().to_string();
  auto ref = VisualReference::create(a, renderer_, small());
  ASSERT_TRUE(ref.ok());
  auto twice = ref->compare(b);
  ASSERT_TRUE(twice.ok());
  EXPECT_NEAR(once->ssim_mean, twice->ssim_mean, 1e-3);  // renderers may differ (EGL vs OSMesa) by a gray level
  EXPECT_LT(once->ssim_mean, 1.0);
}

TEST_F(VisualSimilarityTest, WithoutLineDrawingsTheShadedScoresAreTheSame) {
  const Mesh a = testing::icosphere(4), b = testing::icosphere(2);
  VisualSimilarityOptions shaded_only = small();
  shaded_only.line_drawings = false;
  auto full = VisualReference::create(a, renderer_, small());
  auto fast = VisualReference::create(a, renderer_, shaded_only);
  ASSERT_TRUE(full.ok() && fast.ok());
  auto with_lines = full->compare(b);
  auto without = fast->compare(b);
  ASSERT_TRUE(with_lines.ok() && without.ok());
  ASSERT_LT(with_lines->ssim_mean, 1.0);
  EXPECT_EQ(without->ssim_mean, with_lines->ssim_mean);
  EXPECT_EQ(without->ssim_worst, with_lines->ssim_worst);
  EXPECT_EQ(without->ssim_worst_view, with_lines->ssim_worst_view);
  EXPECT_TRUE(std::isfinite(with_lines->line_mean));
  EXPECT_TRUE(std::isnan(without->line_mean));  // not computed, and not mistaken for a score
  EXPECT_TRUE(std::isnan(without->line_worst));
  ASSERT_EQ(without->per_view.size(), with_lines->per_view.size());
  EXPECT_TRUE(std::isnan(without->per_view[0].line_ssim));
}

TEST_F(VisualSimilarityTest, RejectsInvalidMeshes) {
  auto ref = VisualReference::create(testing::icosphere(2), renderer_, small());
  ASSERT_TRUE(ref.ok());
  Mesh bad = testing::icosphere(1);
  bad.indices[0] = 1000;
  auto v = ref->compare(bad);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.status().message().find("candidate"), std::string::npos);
  EXPECT_FALSE(VisualReference::create(Mesh{}, renderer_, small()).ok());
}

}  // namespace
}  // namespace vpr
