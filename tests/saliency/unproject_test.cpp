// Stage 3: pixels back to model space through the depth buffer.
#include "saliency/unproject.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "render/snapshot.h"
#include "render/views.h"
#include "test_meshes.h"

namespace vpr {
namespace {

Mesh cube(double h) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 3; ++k) m.positions.push_back(float((i >> k) & 1 ? h : -h));
  m.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
               2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  return m;
}

std::vector<View> views_of(const Mesh& mesh, int resolution, bool pca) {
  ViewOptions options;
  options.resolution = resolution;
  options.pca_align = pca;
  auto views = make_views(mesh, options);
  EXPECT_TRUE(views.ok()) << views.status().to_string();
  return views.ok() ? *views : std::vector<View>{};
}

Mask all_features(int w, int h) {
  return Mask(w, h, 1);
}

TEST(Unproject, PixelCentresAndDepthsRoundTripInRowOrder) {
  const Mesh mesh = testing::icosphere(1, 3.0f);
  const View view = views_of(mesh, 64, false)[2];
  FloatImage depth(64, 64, 1.0f);
  Mask features(64, 64, 0);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      depth.at(x, y) = 0.2f + 0.01f * float(x % 50) + 0.003f * float(y);
      features.at(x, y) = (x + y) % 3 != 0;
    }
  depth.at(5, 7) = 1.0f;                     // background: skipped though marked as a feature
  std::vector<float> points = {42, 42, 42};  // appended to, not replaced
  ASSERT_TRUE(cpu::unproject_features(features, depth, view, &points, ExecContext{}).ok());
  ASSERT_EQ(points[0], 42.0f);
  size_t i = 1;
  double worst_px = 0, worst_depth = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      if (!features.at(x, y) || depth.at(x, y) == 1.0f) continue;
      ASSERT_LT(3 * i + 2, points.size());
      const Vec3d ndc = transform_point(view.view_proj, load3d(points.data(), i++));
      // Row 0 is the top; GL's window y counts from the bottom.
      worst_px = std::max(worst_px, std::abs((ndc.x + 1) * 32 - (x + 0.5)));
      worst_px = std::max(worst_px, std::abs((ndc.y + 1) * 32 - (64 - y - 0.5)));
      worst_depth = std::max(worst_depth, std::abs((ndc.z + 1) * 0.5 - depth.at(x, y)));
    }
  EXPECT_EQ(points.size(), 3 * i);
  EXPECT_LT(worst_px, 1e-4);
  EXPECT_LT(worst_depth, 1e-6);
}

TEST(Unproject, RejectsMismatchedImages) {
  const View view = views_of(cube(1), 32, false)[0];
  std::vector<float> points;
  EXPECT_EQ(cpu::unproject_features(Mask(32, 31), FloatImage(32, 32), view, &points, ExecContext{}).code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::unproject_features(Mask(16, 16), FloatImage(16, 16), view, &points, ExecContext{}).code(),
            StatusCode::kInvalidArgument);
  EXPECT_TRUE(points.empty());
}

class UnprojectRendered : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = create_renderer(RendererKind::kOsmesa);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    renderer_ = std::move(r).value();
  }
  std::unique_ptr<Renderer> renderer_;
};

TEST_F(UnprojectRendered, TiltedQuadPointsLieOnTheQuad) {
  // A 4 x 3 quad in the plane spanned by u and v through o.
  const Vec3d o{1, -2, 0.5}, u{2 / 3.0, 1 / 3.0, 2 / 3.0}, v{-2 / 3.0, 2 / 3.0, 1 / 3.0};  // orthonormal
  const Vec3d n = cross(u, v);
  Mesh quad;
  for (auto [a, b] : {std::pair{-2.0, -1.5}, {2.0, -1.5}, {2.0, 1.5}, {-2.0, 1.5}}) {
    const Vec3d p = o + u * a + v * b;
    quad.positions.insert(quad.positions.end(), {float(p.x), float(p.y), float(p.z)});
  }
  quad.indices = {0, 1, 2, 0, 2, 3};
  const double diagonal = bounding_box(quad).diagonal();
  const std::vector<View> views = views_of(quad, 256, false);
  std::vector<Snapshot> shots;
  ASSERT_TRUE(renderer_->render(quad, views, &shots).ok());
  size_t total = 0;
  double worst_plane = 0, worst_outside = 0;
  for (size_t k = 0; k < views.size(); ++k) {
    std::vector<float> points;
    ASSERT_TRUE(cpu::unproject_features(shots[k].coverage, shots[k].depth, views[k], &points, ExecContext{}).ok());
    size_t covered = 0;
    for (uint8_t c : shots[k].coverage.pixels) covered += c;
    ASSERT_EQ(points.size(), 3 * covered) << views[k].name;
    EXPECT_GT(covered, 10000u) << views[k].name;  // the quad is oblique to every axis
    total += covered;
    for (size_t i = 0; i < points.size() / 3; ++i) {
      const Vec3d d = load3d(points.data(), i) - o;
      worst_plane = std::max(worst_plane, std::abs(dot(d, n)));
      worst_outside = std::max({worst_outside, std::abs(dot(d, u)) - 2.0, std::abs(dot(d, v)) - 1.5});
    }
  }
  std::printf("%zu points; off the plane by at most %.2e, outside the quad by at most %.2e (diagonal %.2f)\n", total,
              worst_plane, worst_outside, diagonal);
  EXPECT_LT(worst_plane, 1e-3 * diagonal);
  EXPECT_LT(worst_outside, 1e-3 * diagonal);
}

TEST_F(UnprojectRendered, CubeFrontFaceUnprojectsToItsPlane) {
  const Mesh mesh = cube(0.5);
  const std::vector<View> views = views_of(mesh, 200, true);  // a cube aligns to itself
  std::vector<Snapshot> shots;
  ASSERT_TRUE(renderer_->render(mesh, views, &shots).ok());
  const View& pz = views[4];
  ASSERT_EQ(pz.name, "+z");
  std::vector<float> points;
  ASSERT_TRUE(cpu::unproject_features(shots[4].coverage, shots[4].depth, pz, &points, ExecContext{}).ok());
  ASSERT_GT(points.size(), 3u * 30000);  // 180 x 180 px face
  double worst_z = 0, worst_xy = 0;
  for (size_t i = 0; i < points.size() / 3; ++i) {
    worst_z = std::max(worst_z, std::abs(points[3 * i + 2] - 0.5));
    worst_xy = std::max({worst_xy, std::abs(double(points[3 * i])), std::abs(double(points[3 * i + 1]))});
  }
  std::printf("+z face: %zu points, |z - 0.5| <= %.2e, |x|,|y| <= %.6f\n", points.size() / 3, worst_z, worst_xy);
  EXPECT_LT(worst_z, 1e-4);
  EXPECT_LE(worst_xy, 0.5);
}

}  // namespace
}  // namespace vpr
