// Stage 1 cameras: framing, matrix inverses, principal-axis alignment.
#include "render/views.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "render/orientation.h"
#include "test_meshes.h"

namespace vpr {
namespace {

using Mat3 = std::array<double, 9>;

// Closed box [lo, hi] as 8 vertices and 12 outward triangles.
Mesh box(Vec3d lo, Vec3d hi) {
  Mesh m;
  for (int i = 0; i < 8; ++i) {
    m.positions.push_back(float(i & 1 ? hi.x : lo.x));
    m.positions.push_back(float(i & 2 ? hi.y : lo.y));
    m.positions.push_back(float(i & 4 ? hi.z : lo.z));
  }
  m.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
               2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  return m;
}

// Rotation about a unit axis by an angle (Rodrigues), row-major.
Mat3 rotation(Vec3d axis, double angle) {
  axis = axis * (1.0 / norm(axis));
  const double c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  const double x = axis.x, y = axis.y, z = axis.z;
  // clang-format off
  return {t * x * x + c,     t * x * y - s * z, t * x * z + s * y,
          t * x * y + s * z, t * y * y + c,     t * y * z - s * x,
          t * x * z - s * y, t * y * z + s * x, t * z * z + c};
  // clang-format on
}

Vec3d apply(const Mat3& r, Vec3d v) {
  return {r[0] * v.x + r[1] * v.y + r[2] * v.z, r[3] * v.x + r[4] * v.y + r[5] * v.z,
          r[6] * v.x + r[7] * v.y + r[8] * v.z};
}

Vec3d row(const Mat3& r, int i) {
  return {r[3 * i], r[3 * i + 1], r[3 * i + 2]};
}
Vec3d column(const Mat3& r, int i) {
  return {r[i], r[3 + i], r[6 + i]};
}

Mesh transformed(const Mesh& in, const Mat3& r, Vec3d t) {
  Mesh m = in;
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const Vec3d p = apply(r, load3d(in.positions.data(), v)) + t;
    m.positions[3 * v] = float(p.x);
    m.positions[3 * v + 1] = float(p.y);
    m.positions[3 * v + 2] = float(p.z);
  }
  return m;
}

// An irregular closed tetrahedron: distinct principal variances and nonzero
// skew along every axis, so its frame is fully determined by the data.
Mesh lopsided_tetrahedron() {
  Mesh m;
  m.positions = {0, 0, 0, 4, 0, 0, 0.3f, 2, 0, 0.2f, 0.1f, 1};
  m.indices = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
  return m;
}

Vec3d window(const View& v, Vec3d p) {  // pixels (GL, bottom-up) and depth in [0, 1]
  const Vec3d n = transform_point(v.view_proj, p);
  return {(n.x + 1) * 0.5 * v.width, (n.y + 1) * 0.5 * v.height, (n.z + 1) * 0.5};
}

TEST(Views, SixAndFourteenViewsFrameEveryVertexInsideTheMargin) {
  // A rotated, shifted ellipsoid: PCA alignment is on, so every view sees the
  // aligned model.
  Mesh sphere = testing::icosphere(3);
  for (size_t v = 0; v < sphere.vertex_count(); ++v) {
    sphere.positions[3 * v] *= 3.0f;
    sphere.positions[3 * v + 1] *= 1.5f;
  }
  const Mesh mesh = transformed(sphere, rotation({1, 2, 3}, 0.7), {10, -5, 2});
  for (int count : {6, 14}) {
    ViewOptions options;
    options.count = count;
    options.resolution = 400;
    options.margin = 0.05f;
    auto views = make_views(mesh, options);
    ASSERT_TRUE(views.ok()) << views.status().to_string();
    ASSERT_EQ(views->size(), size_t(count));
    EXPECT_EQ((*views)[0].name, "+x");
    EXPECT_EQ((*views)[5].name, "-z");
    if (count == 14) EXPECT_EQ((*views)[13].name, "-x-y-z");
    for (const View& view : *views) {
      EXPECT_EQ(view.width, 400);
      EXPECT_EQ(view.height, 400);
      EXPECT_NEAR(norm(Vec3d{view.toward_camera.x, view.toward_camera.y, view.toward_camera.z}), 1.0, 1e-6);
      double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
      for (size_t i = 0; i < mesh.vertex_count(); ++i) {
        const Vec3d w = window(view, load3d(mesh.positions.data(), i));
        const double c[3] = {w.x, w.y, w.z};
        for (int k = 0; k < 3; ++k) {
          lo[k] = std::min(lo[k], c[k]);
          hi[k] = std::max(hi[k], c[k]);
        }
      }
      // 5% of 400 px = 20 px of border on each side, and the larger extent
      // touches it: the framing is tight.
      EXPECT_GE(lo[0], 20.0 - 1e-6) << view.name;
      EXPECT_GE(lo[1], 20.0 - 1e-6) << view.name;
      EXPECT_LE(hi[0], 380.0 + 1e-6) << view.name;
      EXPECT_LE(hi[1], 380.0 + 1e-6) << view.name;
      EXPECT_NEAR(std::max(hi[0] - lo[0], hi[1] - lo[1]), 360.0, 1e-6) << view.name;
      EXPECT_GT(lo[2], 0.0) << view.name;
      EXPECT_LT(hi[2], 1.0) << view.name;
    }
  }
}

TEST(Views, InverseTimesViewProjectionIsIdentity) {
  ViewOptions options;
  options.count = 14;
  auto views = make_views(transformed(lopsided_tetrahedron(), rotation({0, 1, 1}, 1.1), {100, 0, -3}), options);
  ASSERT_TRUE(views.ok());
  for (const View& v : *views) {
    double worst = 0;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += v.inv_view_proj[k * 4 + r] * v.view_proj[c * 4 + k];
        worst = std::max(worst, std::abs(s - (r == c ? 1.0 : 0.0)));
      }
    EXPECT_LT(worst, 1e-9) << v.name;
  }
}

TEST(Views, CamerasSitWhereTheirNamesSay) {
  // No alignment: the model frame is the camera frame.
  const Mesh mesh = box({-1, -2, -3}, {1, 2, 3});
  ViewOptions options;
  options.count = 14;
  options.pca_align = false;
  auto views = make_views(mesh, options);
  ASSERT_TRUE(views.ok());
  const View& px = (*views)[0];
  EXPECT_NEAR(px.toward_camera.x, 1.0, 1e-7);
  // From +x, the point nearer the camera has the smaller depth, +z is up in
  // the image and +y points right (right = up x back = z x x).
  EXPECT_LT(window(px, {1, 0, 0}).z, window(px, {-1, 0, 0}).z);
  EXPECT_GT(window(px, {0, 0, 3}).y, window(px, {0, 0, -3}).y);
  EXPECT_GT(window(px, {0, 2, 0}).x, window(px, {0, -2, 0}).x);
  // From +z, up is +y.
  const View& pz = (*views)[4];
  EXPECT_EQ(pz.name, "+z");
  EXPECT_GT(window(pz, {0, 2, 0}).y, window(pz, {0, -2, 0}).y);
  EXPECT_LT(window(pz, {0, 0, 3}).z, window(pz, {0, 0, -3}).z);
  const View& diag = (*views)[6];
  EXPECT_EQ(diag.name, "+x+y+z");
  for (float c : {diag.toward_camera.x, diag.toward_camera.y, diag.toward_camera.z})
    EXPECT_NEAR(c, 1.0 / std::sqrt(3.0), 1e-6);
}

TEST(Views, UserRotationReplacesPca) {
  const Mat3 r = rotation({1, 0, 0}, M_PI / 2);  // aligned y = model z
  ViewOptions options;
  options.user_rotation = r;
  const Mesh mesh = box({0, 0, 0}, {1, 1, 1});
  EXPECT_EQ(alignment_rotation(mesh, options), r);
  auto views = make_views(mesh, options);
  ASSERT_TRUE(views.ok());
  const View& py = (*views)[2];
  EXPECT_EQ(py.name, "+y");
  // toward_camera = R^T e_y, the second row of R.
  EXPECT_NEAR(py.toward_camera.x, r[3], 1e-7);
  EXPECT_NEAR(py.toward_camera.y, r[4], 1e-7);
  EXPECT_NEAR(py.toward_camera.z, r[5], 1e-7);
}

TEST(Views, RejectsBadOptionsAndMeshes) {
  const Mesh mesh = box({0, 0, 0}, {1, 1, 1});
  ViewOptions o;
  o.count = 7;
  EXPECT_EQ(make_views(mesh, o).status().code(), StatusCode::kInvalidArgument);
  o = ViewOptions{};
  o.margin = 0.5f;
  EXPECT_EQ(make_views(mesh, o).status().code(), StatusCode::kInvalidArgument);
  o = ViewOptions{};
  o.resolution = 0;
  EXPECT_EQ(make_views(mesh, o).status().code(), StatusCode::kInvalidArgument);
  o = ViewOptions{};
  o.user_rotation = Mat3{1, 0, 0, 0, 1, 0, 0, 0, -1};  // a mirror, not a rotation
  EXPECT_EQ(make_views(mesh, o).status().code(), StatusCode::kInvalidArgument);
  o.user_rotation = Mat3{2, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_EQ(make_views(mesh, o).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(make_views(Mesh{}, ViewOptions{}).status().code(), StatusCode::kInvalidArgument);
  Mesh nan = mesh;
  nan.positions[4] = std::nanf("");
  EXPECT_EQ(make_views(nan, ViewOptions{}).status().code(), StatusCode::kInvalidArgument);
}

TEST(Orientation, RecoversTheLongAxisOfARotatedBox) {
  // 4 x 1.5 x 0.5: distinct principal variances.
  const Mat3 q = rotation({0.3, -1, 2}, 0.9);
  const Mesh mesh = transformed(box({-2, -0.75, -0.25}, {2, 0.75, 0.25}), q, {5, 6, 7});
  const PrincipalAxes axes = surface_principal_axes(mesh);
  for (int k = 0; k < 3; ++k) EXPECT_GT(std::abs(dot(row(axes.rotation, k), column(q, k))), 0.999) << "axis " << k;
  EXPECT_NEAR(axes.centroid.x, 5, 1e-5);
  EXPECT_NEAR(axes.centroid.y, 6, 1e-5);
  EXPECT_NEAR(axes.centroid.z, 7, 1e-5);
  EXPECT_GT(axes.variances[0], axes.variances[1]);
  EXPECT_GT(axes.variances[1], axes.variances[2]);
  // Exact surface variance along the long axis of the box: faces x = +-2 add
  // 2 * 0.75 * 4 each; the four long faces (total area 2*4*(1.5+0.5) = 16)
  // spread x uniformly on [-2, 2], variance 4/3.
  const double end_area = 2 * 1.5 * 0.5, side_area = 16;
  EXPECT_NEAR(axes.variances[0], (end_area * 4 + side_area * 4.0 / 3.0) / (end_area + side_area), 1e-5);
  // Right-handed.
  EXPECT_NEAR(dot(cross(row(axes.rotation, 0), row(axes.rotation, 1)), row(axes.rotation, 2)), 1.0, 1e-9);
}

TEST(Orientation, AlignedFrameDoesNotDependOnTheModelPose) {
  // The sign convention (positive skew) makes the aligned frame a property of
  // the shape: R(Q m) Q = R(m) for any rotation Q.
  const Mesh base = lopsided_tetrahedron();
  const Mat3 r0 = surface_principal_axes(base).rotation;
  for (const Mat3& q : {rotation({1, 1, 0}, 2.5), rotation({0, 0, 1}, M_PI), rotation({-1, 2, 0.5}, 4.0)}) {
    const Mat3 r1 = surface_principal_axes(transformed(base, q, {3, -1, 8})).rotation;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double rq = 0;
        for (int k = 0; k < 3; ++k) rq += r1[3 * i + k] * q[3 * k + j];
        EXPECT_NEAR(rq, r0[3 * i + j], 1e-5) << i << "," << j;
      }
  }
}

TEST(Orientation, IsotropicShapesKeepTheModelAxes) {
  // A cube's covariance is a multiple of the identity: no preferred axes, so
  // the model's own axes stay (instead of eigensolver noise).
  EXPECT_EQ(surface_principal_axes(box({0, 0, 0}, {1, 1, 1})).rotation, (Mat3{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  // A square slab: the thin axis is determined (third), the other two are
  // the model axes in that plane.
  const Mat3 r = surface_principal_axes(box({0, 0, 0}, {2, 2, 0.2})).rotation;
  EXPECT_NEAR(std::abs(r[8]), 1.0, 1e-9);
  EXPECT_NEAR(std::abs(r[0]), 1.0, 1e-9);
  ViewOptions off;
  off.pca_align = false;
  EXPECT_EQ(alignment_rotation(lopsided_tetrahedron(), off), (Mat3{1, 0, 0, 0, 1, 0, 0, 0, 1}));
}

}  // namespace
}  // namespace vpr
