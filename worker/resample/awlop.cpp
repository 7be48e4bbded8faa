// Stage 6 (Section V, Eq. 17-18): AWLOP on the CPU. The per-particle math is in
// awlop_kernels.h; this file finds the neighbours (exact FLANN kd-trees) and
// runs the Jacobi iterations over TBB.
#include "resample/awlop.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <flann/flann.hpp>
#include <limits>
#include <string>
#include <vector>

namespace vpr {
namespace {

using FlannIndex = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

// Exact k-nearest-neighbour queries over a fixed set of points. Queries are
// const and independent, so the answer for one query does not depend on which
// thread asks or in what order.
class KdTree {
 public:
  KdTree(const float* points, size_t n)
      : index_(flann::Matrix<float>(const_cast<float*>(points), n, 3), flann::KDTreeSingleIndexParams(10)) {
    index_.buildIndex();
  }

  // Up to k nearest points to q (itself included if it is in the set), nearest
  // first. Returns how many were found.
  size_t knn(const float* q, size_t k, size_t* indices, float* sq_dists) const {
    flann::KNNSimpleResultSet<float> result(k);
    index_.findNeighbors(result, q, flann::SearchParams(flann::FLANN_CHECKS_UNLIMITED, 0.0f, true));
    const size_t found = std::min(result.size(), k);
    result.copy(indices, sq_dists, found, true);
    return found;
  }

 private:
  FlannIndex index_;
};

bool all_finite(const float* v, size_t count) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// Parallel loop over [0, n) in fixed-size blocks; each block gets its own scratch.
template <class Body>
void for_blocks(size_t n, Body body) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), body);
}

}  // namespace

StatusOr<double> awlop_support_radius(AwlopSupport support, float h_factor, double mean_input_edge, double area,
                                      size_t target) {
  if (!(h_factor > 0) || !std::isfinite(h_factor))
    return invalid_argument("AWLOP h_factor must be a positive finite number, got " + std::to_string(h_factor));
  if (support == AwlopSupport::kPaper) {
    if (!(mean_input_edge > 0) || !std::isfinite(mean_input_edge))
      return invalid_argument("AWLOP kPaper support needs a positive mean input edge length, got " +
                              std::to_string(mean_input_edge));
    return double(h_factor) * mean_input_edge;
  }
  if (!(area > 0) || !std::isfinite(area))
    return invalid_argument("AWLOP kTargetSpacing support needs a positive surface area, got " + std::to_string(area));
  if (target == 0) return invalid_argument("AWLOP kTargetSpacing support needs a target vertex count >= 1");
  return double(h_factor) * std::sqrt(area / double(target));
}

double nearest_neighbor_cv(const float* points, size_t n) {
  if (n < 2) return 0.0;
  const KdTree tree(points, n);
  std::vector<double> nn(n);
  for_blocks(n, [&](const tbb::blocked_range<size_t>& range) {
    size_t idx[2];
    float d2[2];
    for (size_t i = range.begin(); i != range.end(); ++i) {
      const size_t found = tree.knn(points + 3 * i, 2, idx, d2);
      // The point itself is one of the two; the other is its nearest neighbour.
      // A duplicate point may come first, in which case both distances are 0.
      const size_t other = (found > 0 && idx[0] != i) ? 0 : 1;
      nn[i] = std::sqrt(norm2(load3d(points, idx[other]) - load3d(points, i)));
    }
  });
  // Sequential sums: the same value at any thread count.
  double sum = 0, sum2 = 0;
  for (double d : nn) {
    sum += d;
    sum2 += d * d;
  }
  const double mean = sum / double(n);
  if (mean <= 0) return 0.0;
  const double var = std::max(0.0, sum2 / double(n) - mean * mean);
  return std::sqrt(var) / mean;
}

Status check_awlop_args(const float* input_points, size_t np, const float* particles, const float* particle_importance,
                        size_t nx, double h, const AwlopOptions& options) {
  if (np == 0) return invalid_argument("AWLOP needs at least one input point, got 0");
  if (!all_finite(input_points, 3 * np)) return invalid_argument("AWLOP input points contain a non-finite coordinate");
  if (!all_finite(particles, 3 * nx)) return invalid_argument("AWLOP particles contain a non-finite coordinate");
  for (size_t i = 0; i < nx; ++i) {
    const float imp = particle_importance[i];
    if (!(imp > 0.0f && imp <= 1.0f))
      return invalid_argument("AWLOP particle importance must lie in (0, 1]; particle " + std::to_string(i) + " has " +
                              std::to_string(imp));
  }
  if (!(h > 0) || !std::isfinite(h))
    return invalid_argument("AWLOP support radius h must be positive and finite, got " + std::to_string(h));
  if (options.k < 1) return invalid_argument("AWLOP k must be >= 1, got " + std::to_string(options.k));
  if (options.iterations < 0)
    return invalid_argument("AWLOP iterations must be >= 0, got " + std::to_string(options.iterations));
  if (!(options.mu >= 0.0f) || !std::isfinite(options.mu))
    return invalid_argument("AWLOP mu must be >= 0 and finite, got " + std::to_string(options.mu));
  return Status::Ok();
}

namespace cpu {

Status awlop(const float* input_points, size_t np, float* particles, const float* particle_importance, size_t nx,
             double h, const AwlopOptions& options, AwlopStats* stats, const ExecContext& /*ctx*/) {
  VPR_RETURN_IF_ERROR(check_awlop_args(input_points, np, particles, particle_importance, nx, h, options));

  if (stats) {
    *stats = AwlopStats{};
    stats->h = h;
    stats->nn_cv_before = nearest_neighbor_cv(particles, nx);
  }
  if (nx == 0) return Status::Ok();

  const double inv_h2 = 1.0 / (h * h);
  const double r_floor = 1e-9 * h;  // guard for r -> 0 in 1/r (Eq. 17-18)
  const double mu = options.mu;
  const size_t k_in = std::min<size_t>(size_t(options.k), np);
  // +1: a particle finds itself among its particle neighbours and skips it.
  const size_t k_px = std::min<size_t>(size_t(options.k) + 1, nx);

  const KdTree input_tree(input_points, np);

  // v_j = 1 + sum theta over p_j's k nearest other input points (WLOP Eq. 3), once.
  std::vector<double> density(np);
  {
    const size_t k_self = std::min<size_t>(size_t(options.k) + 1, np);
    for_blocks(np, [&](const tbb::blocked_range<size_t>& range) {
      std::vector<size_t> idx(k_self);
      std::vector<float> d2(k_self);
      for (size_t j = range.begin(); j != range.end(); ++j) {
        const size_t found = input_tree.knn(input_points + 3 * j, k_self, idx.data(), d2.data());
        const Vec3d p = load3d(input_points, j);
        double v = 1.0;
        size_t used = 0;
        for (size_t t = 0; t < found && used < size_t(options.k); ++t) {
          if (idx[t] == j) continue;  // the 1 in v_j is p_j itself
          awlop_add_density(&v, p, load3d(input_points, idx[t]), inv_h2);
          ++used;
        }
        density[j] = v;
      }
    });
  }

  // Adaptive repulsion weight w_q = 1 / I(c_q) (Eq. 18).
  std::vector<double> weight(nx);
  for (size_t q = 0; q < nx; ++q) weight[q] = 1.0 / double(particle_importance[q]);

  std::vector<float> current(particles, particles + 3 * nx);
  std::vector<float> next(3 * nx);
  for (int it = 0; it < options.iterations; ++it) {
    const KdTree particle_tree(current.data(), nx);  // particles moved: rebuild
    for_blocks(nx, [&](const tbb::blocked_range<size_t>& range) {
      std::vector<size_t> idx(std::max(k_in, k_px));
      std::vector<float> d2(idx.size());
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const float* xf = current.data() + 3 * i;
        const Vec3d x = load3d(current.data(), i);

        // Eq. (17): attraction to the density-weighted average of nearby inputs.
        AwlopSum attraction;
        size_t found = input_tree.knn(xf, k_in, idx.data(), d2.data());
        double r2_min = std::numeric_limits<double>::infinity();
        for (size_t t = 0; t < found; ++t) r2_min = std::min(r2_min, norm2(load3d(input_points, idx[t]) - x));
        for (size_t t = 0; t < found; ++t)
          awlop_add_attraction(&attraction, x, load3d(input_points, idx[t]), density[idx[t]], r2_min, inv_h2, r_floor);

        // Eq. (18): repulsion from the k nearest other particles, weighted by 1 / I.
        AwlopSum repulsion;
        found = particle_tree.knn(xf, k_px, idx.data(), d2.data());
        r2_min = std::numeric_limits<double>::infinity();
        size_t kept = 0;
        for (size_t t = 0; t < found; ++t) {
          if (idx[t] == i) continue;
          idx[kept++] = idx[t];
        }
        kept = std::min(kept, size_t(options.k));
        for (size_t t = 0; t < kept; ++t) r2_min = std::min(r2_min, norm2(load3d(current.data(), idx[t]) - x));
        for (size_t t = 0; t < kept; ++t)
          awlop_add_repulsion(&repulsion, x, load3d(current.data(), idx[t]), weight[idx[t]], r2_min, inv_h2, r_floor);

        const Vec3d moved = awlop_update(x, attraction, repulsion, mu);
        store3(next.data(), i, Vec3{float(moved.x), float(moved.y), float(moved.z)});
      }
    });
    current.swap(next);  // Jacobi: the next iteration reads only these positions
  }

  std::copy(current.begin(), current.end(), particles);
  if (stats) {
    stats->iterations = options.iterations;
    stats->nn_cv_after = nearest_neighbor_cv(particles, nx);
  }
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
