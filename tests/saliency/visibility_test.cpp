// The visibility cue (visibility.h) on rendered shapes whose answer we know: a
// sphere hidden inside another is seen by no view, the outer sphere's vertices
// by some but never by all six; on a cube seen along its axes every corner and
// edge lies on the silhouette of the side-on views (the 3 x 3 rule counts it as
// seen), so corners are seen by all six views and the middle of a face by all
// but the opposite one; bad arguments are refused.
#include "saliency/visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "../test_meshes.h"

namespace vpr {
namespace {

const ExecContext kCpu{};

class Visibility : public ::testing::Test {
 protected:
  void SetUp() override {
    auto r = create_renderer(RendererKind::kOsmesa);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    renderer_ = std::move(r).value();
  }
  // Views of `mesh` (axis-aligned, 256 px) and the visibility of its vertices.
  std::vector<float> visibility_of(const Mesh& mesh, int count = 6) {
    ViewOptions o;
    o.count = count;
    o.resolution = 256;
    o.pca_align = false;
    auto views = make_views(mesh, o);
    EXPECT_TRUE(views.ok());
    std::vector<Snapshot> shots;
    EXPECT_TRUE(renderer_->render(mesh, *views, &shots).ok());
    std::vector<float> vis;
    const Status s = cpu::view_visibility(mesh.positions.data(), mesh.vertex_count(), *views, shots, {}, &vis, kCpu);
    EXPECT_TRUE(s.ok()) << s.to_string();
    return vis;
  }
  std::unique_ptr<Renderer> renderer_;
};

TEST_F(Visibility, AHiddenSphereIsSeenByNoViewAndTheOuterOneByHalf) {
  Mesh both = testing::icosphere(3, 1.0f);
  const size_t outer = both.vertex_count();
  const Mesh inner = testing::icosphere(2, 0.5f);
  for (float x : inner.positions) both.positions.push_back(x);
  for (uint32_t i : inner.indices) both.indices.push_back(i + uint32_t(outer));
  const std::vector<float> vis = visibility_of(both);
  ASSERT_EQ(vis.size(), both.vertex_count());
  double sum = 0;
  for (size_t v = 0; v < outer; ++v) {
    EXPECT_GE(vis[v], 1.0f / 6 - 1e-6f) << "outer vertex " << v;
    EXPECT_LE(vis[v], 5.0f / 6 + 1e-6f) << "outer vertex " << v;
    sum += vis[v];
  }
  // Each point of a sphere faces half the directions; the silhouette rule adds a little.
  EXPECT_GT(sum / double(outer), 0.45);
  EXPECT_LT(sum / double(outer), 0.7);
  for (size_t v = outer; v < both.vertex_count(); ++v) EXPECT_EQ(vis[v], 0.0f) << "inner vertex " << v;
}

TEST_F(Visibility, CubeFaceCentresAreHiddenOnlyFromTheOppositeView) {
  // A unit cube with one extra vertex at the centre of each face (4 triangles a face).
  Mesh cube;
  for (int i = 0; i < 8; ++i)
    cube.positions.insert(cube.positions.end(), {float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    const uint32_t c = uint32_t(cube.vertex_count());
    for (int a = 0; a < 3; ++a) {
      float m = 0;
      for (int k = 0; k < 4; ++k) m += cube.positions[3 * f[k] + a] / 4;
      cube.positions.push_back(m);
    }
    for (int k = 0; k < 4; ++k) cube.indices.insert(cube.indices.end(), {uint32_t(f[k]), uint32_t(f[(k + 1) % 4]), c});
  }
  const std::vector<float> vis = visibility_of(cube);
  for (int v = 0; v < 8; ++v) EXPECT_EQ(vis[v], 1.0f) << "corner " << v;
  for (int v = 8; v < 14; ++v) EXPECT_NEAR(vis[v], 5.0f / 6, 1e-6f) << "face centre " << v;
}

TEST_F(Visibility, RefusesMismatchedViewsAndNoViewsMeansSeen) {
  const Mesh m = testing::icosphere(1);
  ViewOptions o;
  o.resolution = 64;
  auto views = make_views(m, o);
  ASSERT_TRUE(views.ok());
  std::vector<Snapshot> shots;
  ASSERT_TRUE(renderer_->render(m, *views, &shots).ok());
  std::vector<float> vis;
  std::vector<Snapshot> fewer(shots.begin(), shots.end() - 1);
  EXPECT_EQ(cpu::view_visibility(m.positions.data(), m.vertex_count(), *views, fewer, {}, &vis, kCpu).code(),
            StatusCode::kInvalidArgument);
  VisibilityOptions bad;
  bad.depth_tolerance = -1;
  EXPECT_EQ(cpu::view_visibility(m.positions.data(), m.vertex_count(), *views, shots, bad, &vis, kCpu).code(),
            StatusCode::kInvalidArgument);
  bad = {};
  bad.view_bias = 1.5f;
  EXPECT_EQ(cpu::view_visibility(m.positions.data(), m.vertex_count(), *views, shots, bad, &vis, kCpu).code(),
            StatusCode::kInvalidArgument);
  ASSERT_TRUE(cpu::view_visibility(m.positions.data(), m.vertex_count(), {}, {}, {}, &vis, kCpu).ok());
  EXPECT_EQ(vis, std::vector<float>(m.vertex_count(), 1.0f));
}

// Views weighted towards the front and top: with b = 1 a view 45 degrees from
// the front-top direction weighs (1 + cos 45)/2, one facing away from it
// (1 - cos 45)/2, a side view 1/2; with b = 0 all weigh 1.
TEST_F(Visibility, WeightsViewsTowardsTheFrontAndTop) {
  std::vector<View> views(6);
  const Vec3 dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 6; ++i) views[i].toward_camera = dirs[i];
  VisibilityOptions o;
  EXPECT_EQ(view_weights(views, o), std::vector<double>(6, 1.0));
  o.view_bias = 1.0f;
  const std::vector<double> w = view_weights(views, o);
  const double c = std::sqrt(0.5);
  const double expected[6] = {0.5, 0.5, 0.5 * (1 + c), 0.5 * (1 - c), 0.5 * (1 + c), 0.5 * (1 - c)};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(w[i], expected[i], 1e-6) << "view " << i;
  o.view_bias = 0.5f;
  EXPECT_NEAR(view_weights(views, o)[3], 0.5 + 0.5 * 0.5 * (1 - c), 1e-6);
}

}  // namespace
}  // namespace vpr
