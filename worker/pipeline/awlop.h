// Stage 6 (Section V, Eq. 17-18): adaptive weighted locally optimal projection.
// Each iteration moves every particle x_i to the density-weighted average of the
// input points near it (attraction, Eq. 17) plus mu times a repulsion from the
// other particles weighted by w_q = 1 / I(c_q) (Eq. 18).
#pragma once

#include <cstdint>
#include <vector>

#include "exec_context.h"
#include "status.h"

namespace vpr {

enum class AwlopSupport {
  kPaper,          // h = h_factor * mean input edge length (the paper's h)
  kTargetSpacing,  // h = h_factor * sqrt(area / target): spacing of the output
};

struct AwlopOptions {
  float mu = 0.45f;        // Eq. (17): repulsion strength
  int k = 20;              // neighbours searched for attraction and repulsion (paper: 20)
  int iterations = 10;     // measured default: see docs/performance.md
  AwlopSupport support = AwlopSupport::kTargetSpacing;
  float h_factor = 2.0f;   // h = 2 L_avg
  int attraction_samples_per_target = 4;  // input points: uniform surface samples, 4 per target vertex
};

struct AwlopStats {
  double h = 0;
  int iterations = 0;
  double nn_cv_before = 0;  // coefficient of variation of nearest-neighbour distances
  double nn_cv_after = 0;
};

// theta(r) = exp(-16 r^2 / h^2) (Eq. 17-18).
inline double awlop_theta(double r, double h) { return __builtin_exp(-16.0 * r * r / (h * h)); }

// Coefficient of variation (std / mean) of each point's nearest-neighbour distance.
double nearest_neighbor_cv(const float* points, size_t n);

namespace cpu {

// particles: nx x 3 floats, moved in place; particle_importance: nx values in (0, 1].
// input_points: np x 3 floats on the input surface.
Status awlop(const float* input_points, size_t np, float* particles, const float* particle_importance,
             size_t nx, double h, const AwlopOptions& options, AwlopStats* stats, const ExecContext& ctx);

}  // namespace cpu
}  // namespace vpr
