// Stage 6 (Section V, Eq. 17-18): adaptive weighted locally optimal projection.
// Each iteration moves every particle x_i to the density-weighted average of the
// input points near it (attraction, Eq. 17) plus mu times a repulsion from the
// other particles weighted by w_q = 1 / I(c_q) (Eq. 18).
//
// Our reading, following WLOP (Huang et al. 2009) with the paper's adaptive
// repulsion weight:
//   x_i <- A_i + mu R_i                                               (Eq. 17)
//   A_i = sum_j p_j (alpha_ij / v_j) / sum_j (alpha_ij / v_j),  alpha_ij = theta(|x_i - p_j|) / |x_i - p_j|
//   R_i = sum_q (x_i - x_q) w_q beta_iq / sum_q w_q beta_iq,    beta_iq  = theta(|x_i - x_q|) / |x_i - x_q|
//   v_j = 1 + sum_j' theta(|p_j - p_j'|)   (input density, once, over p_j's k nearest inputs)
//   w_q = 1 / I(c_q)                        (Eq. 18: the adaptive weight)
// j runs over the k nearest input points of x_i (kd-tree built once), q over
// the k nearest other particles (kd-tree rebuilt every iteration). The update
// is Jacobi: every particle reads the previous iteration's positions, so the
// result does not depend on the thread count. Per-particle math: awlop_kernels.h.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "resample/awlop_kernels.h"
#include "core/exec_context.h"
#include "core/status.h"

namespace vpr {

// Where the support radius h of theta comes from (the caller computes h with
// awlop_support_radius and passes it to awlop).
enum class AwlopSupport {
  // h = h_factor * mean input edge length: the paper's h. On a dense input the
  // input edges are much shorter than the particle spacing, theta has decayed
  // to nothing at the nearest particle, and repulsion reduces to "step away
  // from the single nearest particle". Measured (unit sphere, 100k uniform
  // input points, h = 2 x input spacing = 0.022, 2k uniform random particles,
  // NN-distance CV 0.52 at start): CV 0.29 after 10 iterations, then ~0.28.
  kPaper,
  // h = h_factor * sqrt(area / target): the spacing of the output, so theta
  // spans the particle's own neighbourhood whatever the input density. Same
  // measurement (h = 0.159): CV 0.15 after 10 iterations, 0.14 after 15-20,
  // 0.13 after 40.
  kTargetSpacing,
};

struct AwlopOptions {
  float mu = 0.45f;  // Eq. (17): repulsion strength
  int k = 20;        // neighbours searched for attraction and repulsion (paper: 20)
  // Measured default: with kTargetSpacing, 10 iterations give ~95% of the CV
  // reduction that 40 do (see AwlopSupport).
  int iterations = 10;
  AwlopSupport support = AwlopSupport::kTargetSpacing;
  float h_factor = 2.0f;  // h = h_factor x the length `support` names (paper: 2 L_avg)
  int attraction_samples_per_target =
      8;  // input points: uniform surface samples per target vertex (measured: docs/pipeline.md)
};

struct AwlopStats {
  double h = 0;
  int iterations = 0;
  double nn_cv_before = 0;  // coefficient of variation of nearest-neighbour distances
  double nn_cv_after = 0;
};

// theta(r) = exp(-16 r^2 / h^2) (Eq. 17-18).
inline double awlop_theta(double r, double h) {
  return std::exp(-16.0 * r * r / (h * h));
}

// The support radius h for `support` (see AwlopSupport). mean_input_edge: mean
// edge length of the input mesh; area: its total area; target: output vertex
// count. INVALID_ARGUMENT when the chosen formula has a non-positive or
// non-finite input (h_factor, edge length, area or target).
StatusOr<double> awlop_support_radius(AwlopSupport support, float h_factor, double mean_input_edge, double area,
                                      size_t target);

// Coefficient of variation (std / mean) of each point's nearest-neighbour
// distance (exact kd-tree search); points: n x 3 floats. 0 when n < 2 or all
// distances are 0. A uniform random (Poisson) sample of a surface has CV ~0.52;
// a blue-noise sample much less.
double nearest_neighbor_cv(const float* points, size_t n);

// The argument checks of awlop below, shared by the CPU and GPU twins.
Status check_awlop_args(const float* input_points, size_t np, const float* particles, const float* particle_importance,
                        size_t nx, double h, const AwlopOptions& options);

namespace cpu {

// particles: nx x 3 floats, moved in place; particle_importance: nx values in (0, 1].
// input_points: np x 3 floats on the input surface. h: support radius of theta,
// model units (awlop_support_radius). stats may be null.
// INVALID_ARGUMENT for np == 0, non-finite coordinates, importance outside
// (0, 1], h <= 0, k < 1, iterations < 0 or mu < 0. Threads: TBB's current arena.
Status awlop(const float* input_points, size_t np, float* particles, const float* particle_importance, size_t nx,
             double h, const AwlopOptions& options, AwlopStats* stats, const ExecContext& ctx);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (awlop.cu): the same Jacobi iterations
// with the same neighbour sets (exact grid k-NN, rebuilt every iteration as
// the particles move); the result agrees with the CPU twin's to ~1e-4 of the
// bounding-box diagonal (exp and the order of float sums differ in the last
// bits). Host arrays in and out; the work runs on ctx's stream, device memory
// is charged to ctx.budget. k > 64 is UNAVAILABLE (use the CPU twin).
namespace cuda {

Status awlop(const float* input_points, size_t np, float* particles, const float* particle_importance, size_t nx,
             double h, const AwlopOptions& options, AwlopStats* stats, const ExecContext& ctx);

}  // namespace cuda
}  // namespace vpr
