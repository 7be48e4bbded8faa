// Area-weighted principal axes of a triangle surface (see orientation.h).
#include "render/orientation.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace vpr {
namespace {

// Principal variances closer than this (relative to the largest) are treated
// as equal: their axes are then fixed by the model axes, not by float noise.
constexpr double kEqualVarianceTolerance = 1e-3;
// Third moments below this fraction of sigma^3 are treated as zero (symmetric).
constexpr double kSkewTolerance = 1e-4;

// Faces per block of the moment sums. Each block is summed on its own and the
// blocks are added in order, so the sums (and the axes) do not depend on the
// thread count.
constexpr size_t kBlock = 8192;

Eigen::Vector3d to_eigen(Vec3d v) {
  return {v.x, v.y, v.z};
}

// The model axis least aligned with `normal`, projected onto the plane
// orthogonal to it. Ties go to the lower axis index, so it is deterministic.
Eigen::Vector3d model_axis_in_plane(const Eigen::Vector3d& normal) {
  int best = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(normal[a]) < std::abs(normal[best])) best = a;
  Eigen::Vector3d e = Eigen::Vector3d::Unit(best);
  return (e - normal * normal.dot(e)).normalized();
}

// Largest-magnitude component positive; ties go to the lower index.
void make_largest_component_positive(Eigen::Vector3d* axis) {
  int best = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs((*axis)[a]) > std::abs((*axis)[best]) + 1e-12) best = a;
  if ((*axis)[best] < 0) *axis = -*axis;
}

}  // namespace

PrincipalAxes surface_principal_axes(const Mesh& mesh) {
  PrincipalAxes result;
  const size_t nf = mesh.face_count();
  if (nf == 0) return result;
  const float* p = mesh.positions.data();

  // Work relative to the box centre so that far-from-origin scans keep their
  // precision in the second and third moments.
  const Aabb box = bounding_box(mesh);
  const Vec3d origin{0.5 * (double(box.lo[0]) + box.hi[0]), 0.5 * (double(box.lo[1]) + box.hi[1]),
                     0.5 * (double(box.lo[2]) + box.hi[2])};

  // Exact integrals over each triangle (uniform density): with vertices a, b, c
  // and centroid m, the mean of x x^T is (a a^T + b b^T + c c^T + 9 m m^T) / 12.
  struct Moments {
    double area = 0.0;
    Eigen::Vector3d first = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  };
  std::vector<Moments> blocks((nf + kBlock - 1) / kBlock);
  tbb::parallel_for(size_t(0), blocks.size(), [&](size_t blk) {
    Moments& m = blocks[blk];
    for (size_t f = blk * kBlock; f < std::min(nf, (blk + 1) * kBlock); ++f) {
      const Eigen::Vector3d a = to_eigen(load3d(p, mesh.indices[3 * f]) - origin);
      const Eigen::Vector3d b = to_eigen(load3d(p, mesh.indices[3 * f + 1]) - origin);
      const Eigen::Vector3d c = to_eigen(load3d(p, mesh.indices[3 * f + 2]) - origin);
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (!(area > 0.0)) continue;
      const Eigen::Vector3d centroid = (a + b + c) / 3.0;
      m.area += area;
      m.first += area * centroid;
      m.second += area / 12.0 *
                  (a * a.transpose() + b * b.transpose() + c * c.transpose() + 9.0 * centroid * centroid.transpose());
    }
  });
  double area_sum = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const Moments& m : blocks) {
    area_sum += m.area;
    first += m.first;
    second += m.second;
  }
  if (!(area_sum > 0.0)) return result;
  const Eigen::Vector3d mean = first / area_sum;
  const Eigen::Matrix3d covariance = second / area_sum - mean * mean.transpose();
  result.centroid = Vec3d{mean.x(), mean.y(), mean.z()} + origin;

  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  // Eigen sorts ascending; we want the largest variance first.
  const Eigen::Vector3d values = solver.eigenvalues().reverse();
  Eigen::Matrix3d axes = solver.eigenvectors().rowwise().reverse();  // columns: axis 1, 2, 3
  for (int k = 0; k < 3; ++k) result.variances[k] = std::max(0.0, values[k]);

  const double scale = std::max(values[0], 1e-300);
  const bool eq12 = (values[0] - values[1]) <= kEqualVarianceTolerance * scale;
  const bool eq23 = (values[1] - values[2]) <= kEqualVarianceTolerance * scale;
  if (eq12 && eq23) {
    axes.setIdentity();  // isotropic: the data prefers no direction
  } else if (eq12) {
    const Eigen::Vector3d n = axes.col(2);
    axes.col(0) = model_axis_in_plane(n);
    axes.col(1) = n.cross(axes.col(0));
  } else if (eq23) {
    const Eigen::Vector3d n = axes.col(0);
    axes.col(1) = model_axis_in_plane(n);
    axes.col(2) = n.cross(axes.col(1));
  }

  // Signs of axes 1 and 2: the third moment of the surface along the axis
  // should be positive. For a triangle and a linear function u with vertex
  // values u0, u1, u2, the mean of u^3 is h3(u0, u1, u2) / 10, h3 being the
  // complete homogeneous symmetric polynomial of degree 3.
  struct Skew {
    double third[2] = {0, 0}, var[2] = {0, 0};
  };
  std::vector<Skew> skews(blocks.size());
  tbb::parallel_for(size_t(0), skews.size(), [&](size_t blk) {
    Skew& sk = skews[blk];
    for (size_t f = blk * kBlock; f < std::min(nf, (blk + 1) * kBlock); ++f) {
      const Eigen::Vector3d a = to_eigen(load3d(p, mesh.indices[3 * f]) - origin) - mean;
      const Eigen::Vector3d b = to_eigen(load3d(p, mesh.indices[3 * f + 1]) - origin) - mean;
      const Eigen::Vector3d c = to_eigen(load3d(p, mesh.indices[3 * f + 2]) - origin) - mean;
      const double area = 0.5 * (b - a).cross(c - a).norm();
      if (!(area > 0.0)) continue;
      for (int k = 0; k < 2; ++k) {
        const double u0 = axes.col(k).dot(a), u1 = axes.col(k).dot(b), u2 = axes.col(k).dot(c);
        const double h3 = u0 * u0 * u0 + u1 * u1 * u1 + u2 * u2 * u2 + u0 * u0 * (u1 + u2) + u1 * u1 * (u0 + u2) +
                          u2 * u2 * (u0 + u1) + u0 * u1 * u2;
        sk.third[k] += area * h3 / 10.0;
        // The mean of u^2 over the triangle, for the scale of the skew.
        sk.var[k] += area * (u0 * u0 + u1 * u1 + u2 * u2 + u0 * u1 + u1 * u2 + u0 * u2) / 6.0;
      }
    }
  });
  double third[2] = {0, 0}, var[2] = {0, 0};
  for (const Skew& sk : skews)
    for (int k = 0; k < 2; ++k) {
      third[k] += sk.third[k];
      var[k] += sk.var[k];
    }
  for (int k = 0; k < 2; ++k) {
    Eigen::Vector3d axis = axes.col(k);
    const double sigma = std::sqrt(std::max(var[k] / area_sum, 0.0));
    if (std::abs(third[k] / area_sum) > kSkewTolerance * sigma * sigma * sigma) {
      if (third[k] < 0) axis = -axis;
    } else {
      make_largest_component_positive(&axis);
    }
    axes.col(k) = axis;
  }
  axes.col(2) = axes.col(0).cross(axes.col(1)).normalized();

  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) result.rotation[3 * r + c] = axes(c, r);
  return result;
}

}  // namespace vpr
