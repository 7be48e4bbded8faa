// Stage 1 (Section III): the six (or fourteen) orthographic cameras.
//
// Model space -> aligned frame: a = R (x - c), R from alignment_rotation(), c
// the model's bounding-box centre. Every view looks at the aligned model from
// one side; its orthographic frustum is the tight square around the model's
// projection plus `margin`, and its depth range hugs the model, so the whole
// depth buffer precision goes to the surface.
#include "render/views.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "render/orientation.h"

namespace vpr {
namespace {

using Mat3 = std::array<double, 9>;  // row-major

Mat4 identity4() {
  return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
}

Mat4 multiply(const Mat4& a, const Mat4& b) {  // column-major a * b
  Mat4 r{};
  for (int c = 0; c < 4; ++c)
    for (int rr = 0; rr < 4; ++rr) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + rr] * b[c * 4 + k];
      r[c * 4 + rr] = s;
    }
  return r;
}

// 4x4 affine matrix (column-major) for y = M x + t, M row-major 3x3.
Mat4 affine(const Mat3& m, Vec3d t) {
  Mat4 r = identity4();
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) r[col * 4 + row] = m[3 * row + col];
  r[12] = t.x;
  r[13] = t.y;
  r[14] = t.z;
  return r;
}

Vec3d apply(const Mat3& m, Vec3d v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}
Vec3d apply_transposed(const Mat3& m, Vec3d v) {
  return {m[0] * v.x + m[3] * v.y + m[6] * v.z, m[1] * v.x + m[4] * v.y + m[7] * v.z,
          m[2] * v.x + m[5] * v.y + m[8] * v.z};
}

Vec3d normalized(Vec3d v) {
  return v * (1.0 / norm(v));
}

// glOrtho(l, r, b, t, n, f) as a column-major matrix.
Mat4 ortho(double l, double r, double b, double t, double n, double f) {
  Mat4 m{};
  m[0] = 2.0 / (r - l);
  m[5] = 2.0 / (t - b);
  m[10] = -2.0 / (f - n);
  m[12] = -(r + l) / (r - l);
  m[13] = -(t + b) / (t - b);
  m[14] = -(f + n) / (f - n);
  m[15] = 1.0;
  return m;
}

Status check_rotation(const Mat3& r) {
  for (double v : r)
    if (!std::isfinite(v)) return invalid_argument("user rotation has a non-finite entry");
  double worst = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double d = r[3 * i] * r[3 * j] + r[3 * i + 1] * r[3 * j + 1] + r[3 * i + 2] * r[3 * j + 2];
      worst = std::max(worst, std::abs(d - (i == j ? 1.0 : 0.0)));
    }
  const double det =
      r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) + r[2] * (r[3] * r[7] - r[4] * r[6]);
  if (worst > 1e-6 || det < 0)
    return invalid_argument(
        "user rotation must be orthonormal with determinant +1 (tolerance 1e-6); got "
        "R R^T off the identity by " +
        std::to_string(worst) + ", det " + std::to_string(det));
  return Status::Ok();
}

struct Direction {
  const char* name;
  Vec3d toward_camera;  // in the aligned frame, not normalized
};

// Axes first, then the diagonals; the order is part of the contract (tests and
// debug output index views by it).
constexpr int kMaxViews = 14;
const Direction kDirections[kMaxViews] = {
    {"+x", {1, 0, 0}},       {"-x", {-1, 0, 0}},       {"+y", {0, 1, 0}},      {"-y", {0, -1, 0}},
    {"+z", {0, 0, 1}},       {"-z", {0, 0, -1}},       {"+x+y+z", {1, 1, 1}},  {"+x+y-z", {1, 1, -1}},
    {"+x-y+z", {1, -1, 1}},  {"+x-y-z", {1, -1, -1}},  {"-x+y+z", {-1, 1, 1}}, {"-x+y-z", {-1, 1, -1}},
    {"-x-y+z", {-1, -1, 1}}, {"-x-y-z", {-1, -1, -1}},
};

}  // namespace

std::array<double, 9> alignment_rotation(const Mesh& mesh, const ViewOptions& options) {
  if (options.user_rotation) return *options.user_rotation;
  if (!options.pca_align) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  return surface_principal_axes(mesh).rotation;
}

StatusOr<std::vector<View>> make_views(const Mesh& mesh, const ViewOptions& options) {
  if (options.count != 6 && options.count != 14)
    return invalid_argument("view count must be 6 or 14, got " + std::to_string(options.count));
  if (options.resolution < 16 || options.resolution > 8192)
    return invalid_argument("view resolution must be in [16, 8192], got " + std::to_string(options.resolution));
  if (!(options.margin >= 0.0f && options.margin < 0.45f))
    return invalid_argument("view margin must be in [0, 0.45), got " + std::to_string(options.margin));
  const size_t nv = mesh.vertex_count();
  if (nv == 0) return invalid_argument("cannot place cameras around an empty mesh");
  for (float v : mesh.positions)
    if (!std::isfinite(v)) return invalid_argument("mesh has a non-finite coordinate; cameras cannot be placed");
  if (options.user_rotation) VPR_RETURN_IF_ERROR(check_rotation(*options.user_rotation));

  const Aabb box = bounding_box(mesh);
  const double diagonal = box.diagonal();
  if (!(diagonal > 0.0)) return invalid_argument("mesh bounding box is a single point; nothing to photograph");
  const Vec3d centre{0.5 * (double(box.lo[0]) + box.hi[0]), 0.5 * (double(box.lo[1]) + box.hi[1]),
                     0.5 * (double(box.lo[2]) + box.hi[2])};
  const Mat3 rotation = alignment_rotation(mesh, options);
  const Mat4 model_to_aligned = affine(rotation, apply(rotation, centre) * -1.0);

  // Aligned coordinates of every vertex, computed once for all views.
  std::vector<Vec3d> aligned(nv);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 16384), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) aligned[i] = apply(rotation, load3d(mesh.positions.data(), i) - centre);
  });

  const double scale = 1.0 / (1.0 - 2.0 * double(options.margin));
  // Keep the near and far planes a little off the surface: a flat model seen
  // face-on would otherwise have a zero depth range.
  const double depth_pad = 0.01 * diagonal;

  std::vector<View> views;
  views.reserve(size_t(options.count));
  for (int i = 0; i < options.count; ++i) {
    const Vec3d back = normalized(kDirections[i].toward_camera);
    // Up is +z of the aligned frame, except when looking along z, where it is
    // +y. The diagonals are never parallel to z, so their up is +z too.
    const Vec3d up_hint = std::abs(back.z) > 0.9 ? Vec3d{0, 1, 0} : Vec3d{0, 0, 1};
    const Vec3d right = normalized(cross(up_hint, back));
    const Vec3d up = cross(back, right);
    const Mat3 basis{right.x, right.y, right.z, up.x, up.y, up.z, back.x, back.y, back.z};

    // The extent in the view's frame (min and max: exact in any order).
    struct Extent {
      double lo[3], hi[3];
    };
    Extent empty;
    for (int a = 0; a < 3; ++a) {
      empty.lo[a] = std::numeric_limits<double>::infinity();
      empty.hi[a] = -empty.lo[a];
    }
    const Extent extent = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, nv, 16384), empty,
        [&](const tbb::blocked_range<size_t>& r, Extent x) {
          for (size_t i = r.begin(); i < r.end(); ++i) {
            const Vec3d e = apply(basis, aligned[i]);
            const double c[3] = {e.x, e.y, e.z};
            for (int k = 0; k < 3; ++k) {
              x.lo[k] = std::min(x.lo[k], c[k]);
              x.hi[k] = std::max(x.hi[k], c[k]);
            }
          }
          return x;
        },
        [](Extent a, const Extent& b) {
          for (int k = 0; k < 3; ++k) {
            a.lo[k] = std::min(a.lo[k], b.lo[k]);
            a.hi[k] = std::max(a.hi[k], b.hi[k]);
          }
          return a;
        });
    const double* lo = extent.lo;
    const double* hi = extent.hi;
    // Same scale on both image axes: the square around the larger extent.
    // A model that is a segment seen end-on would have zero extent; use the
    // diagonal then so that the projection stays invertible.
    double half = 0.5 * std::max(hi[0] - lo[0], hi[1] - lo[1]) * scale;
    if (!(half > 1e-9 * diagonal)) half = 0.5 * diagonal;
    const double cx = 0.5 * (lo[0] + hi[0]), cy = 0.5 * (lo[1] + hi[1]);
    // The eye looks down -z (its "back" axis); near/far are distances along -z.
    const double near_plane = -(hi[2] + depth_pad), far_plane = -(lo[2] - depth_pad);
    const Mat4 projection = ortho(cx - half, cx + half, cy - half, cy + half, near_plane, far_plane);

    View v;
    v.name = kDirections[i].name;
    v.width = options.resolution;
    v.height = options.resolution;
    v.view_proj = multiply(projection, multiply(affine(basis, {0, 0, 0}), model_to_aligned));
    v.inv_view_proj = invert(v.view_proj);
    const Vec3d toward = apply_transposed(rotation, back);
    v.toward_camera = Vec3{float(toward.x), float(toward.y), float(toward.z)};
    views.push_back(std::move(v));
  }
  return views;
}

Vec3d transform_point(const Mat4& m, Vec3d p) {
  const double x = m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12];
  const double y = m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13];
  const double z = m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14];
  const double w = m[3] * p.x + m[7] * p.y + m[11] * p.z + m[15];
  return {x / w, y / w, z / w};
}

// Cofactor expansion (as in MESA's gluInvertMatrix). Asserts invertibility:
// the matrices here are built by make_views and always are.
Mat4 invert(const Mat4& m) {
  Mat4 inv;
  inv[0] = m[5] * m[10] * m[15] - m[5] * m[11] * m[14] - m[9] * m[6] * m[15] + m[9] * m[7] * m[14] +
           m[13] * m[6] * m[11] - m[13] * m[7] * m[10];
  inv[4] = -m[4] * m[10] * m[15] + m[4] * m[11] * m[14] + m[8] * m[6] * m[15] - m[8] * m[7] * m[14] -
           m[12] * m[6] * m[11] + m[12] * m[7] * m[10];
  inv[8] = m[4] * m[9] * m[15] - m[4] * m[11] * m[13] - m[8] * m[5] * m[15] + m[8] * m[7] * m[13] +
           m[12] * m[5] * m[11] - m[12] * m[7] * m[9];
  inv[12] = -m[4] * m[9] * m[14] + m[4] * m[10] * m[13] + m[8] * m[5] * m[14] - m[8] * m[6] * m[13] -
            m[12] * m[5] * m[10] + m[12] * m[6] * m[9];
  inv[1] = -m[1] * m[10] * m[15] + m[1] * m[11] * m[14] + m[9] * m[2] * m[15] - m[9] * m[3] * m[14] -
           m[13] * m[2] * m[11] + m[13] * m[3] * m[10];
  inv[5] = m[0] * m[10] * m[15] - m[0] * m[11] * m[14] - m[8] * m[2] * m[15] + m[8] * m[3] * m[14] +
           m[12] * m[2] * m[11] - m[12] * m[3] * m[10];
  inv[9] = -m[0] * m[9] * m[15] + m[0] * m[11] * m[13] + m[8] * m[1] * m[15] - m[8] * m[3] * m[13] -
           m[12] * m[1] * m[11] + m[12] * m[3] * m[9];
  inv[13] = m[0] * m[9] * m[14] - m[0] * m[10] * m[13] - m[8] * m[1] * m[14] + m[8] * m[2] * m[13] +
            m[12] * m[1] * m[10] - m[12] * m[2] * m[9];
  inv[2] = m[1] * m[6] * m[15] - m[1] * m[7] * m[14] - m[5] * m[2] * m[15] + m[5] * m[3] * m[14] + m[13] * m[2] * m[7] -
           m[13] * m[3] * m[6];
  inv[6] = -m[0] * m[6] * m[15] + m[0] * m[7] * m[14] + m[4] * m[2] * m[15] - m[4] * m[3] * m[14] -
           m[12] * m[2] * m[7] + m[12] * m[3] * m[6];
  inv[10] = m[0] * m[5] * m[15] - m[0] * m[7] * m[13] - m[4] * m[1] * m[15] + m[4] * m[3] * m[13] +
            m[12] * m[1] * m[7] - m[12] * m[3] * m[5];
  inv[14] = -m[0] * m[5] * m[14] + m[0] * m[6] * m[13] + m[4] * m[1] * m[14] - m[4] * m[2] * m[13] -
            m[12] * m[1] * m[6] + m[12] * m[2] * m[5];
  inv[3] = -m[1] * m[6] * m[11] + m[1] * m[7] * m[10] + m[5] * m[2] * m[11] - m[5] * m[3] * m[10] - m[9] * m[2] * m[7] +
           m[9] * m[3] * m[6];
  inv[7] = m[0] * m[6] * m[11] - m[0] * m[7] * m[10] - m[4] * m[2] * m[11] + m[4] * m[3] * m[10] + m[8] * m[2] * m[7] -
           m[8] * m[3] * m[6];
  inv[11] = -m[0] * m[5] * m[11] + m[0] * m[7] * m[9] + m[4] * m[1] * m[11] - m[4] * m[3] * m[9] - m[8] * m[1] * m[7] +
            m[8] * m[3] * m[5];
  inv[15] = m[0] * m[5] * m[10] - m[0] * m[6] * m[9] - m[4] * m[1] * m[10] + m[4] * m[2] * m[9] + m[8] * m[1] * m[6] -
            m[8] * m[2] * m[5];
  const double det = m[0] * inv[0] + m[1] * inv[4] + m[2] * inv[8] + m[3] * inv[12];
  assert(det != 0.0);
  for (double& v : inv) v /= det;
  return inv;
}

}  // namespace vpr
