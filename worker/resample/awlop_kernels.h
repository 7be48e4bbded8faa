// Per-particle arithmetic of AWLOP (Section V, Eq. 17-18), shared by the CPU
// stage (awlop.cpp) and, later, its CUDA twin: no allocation, no library calls
// beyond <cmath>, every function VPR_HD.
//
// One particle's update is two weighted averages over fixed neighbour lists:
//   attraction  A_i = sum_j p_j a_ij / sum_j a_ij,          a_ij = theta(r_ij) / (r_ij v_j)
//   repulsion   R_i = sum_q (x_i - x_q) b_iq / sum_q b_iq,  b_iq = w_q theta(r_iq) / r_iq
//   x_i <- A_i + mu R_i
// Both are ratios, so any common factor of the weights cancels. We divide every
// weight by theta(r_min) of the nearest neighbour in the list: the result is the
// same formula, but exp(-16 r^2 / h^2) can no longer underflow to 0/0 when h is
// small next to the neighbour distances (kPaper support on a dense input).
#pragma once

#include "core/vec3.h"

namespace vpr {

// Eq. (17-18): theta(r) = exp(-16 r^2 / h^2), written on r^2 to skip a sqrt.
VPR_HD inline double awlop_theta2(double r2, double inv_h2) {
  return std::exp(-16.0 * r2 * inv_h2);
}

// theta(r) / theta(r_min): the shifted kernel above; r2 >= r2_min gives a value in (0, 1].
VPR_HD inline double awlop_theta2_shifted(double r2, double r2_min, double inv_h2) {
  return std::exp(-16.0 * (r2 - r2_min) * inv_h2);
}

// 1/r with r kept away from 0: a particle sitting on an input point (or on
// another particle) would otherwise take all the weight, or divide by zero.
VPR_HD inline double awlop_inv_distance(double r2, double r_floor) {
  const double r = std::sqrt(r2);
  return 1.0 / (r > r_floor ? r : r_floor);
}

// Running weighted sum of one average.
struct AwlopSum {
  Vec3d weighted;     // sum of weight * vector
  double weight = 0;  // sum of weights
};

// Eq. (17): one input point p (density weight v) near particle x.
// r2_min: the smallest squared distance from x among its input neighbours.
VPR_HD inline void awlop_add_attraction(AwlopSum* sum, Vec3d x, Vec3d p, double v, double r2_min, double inv_h2,
                                        double r_floor) {
  const double r2 = norm2(p - x);
  const double a = awlop_theta2_shifted(r2, r2_min, inv_h2) * awlop_inv_distance(r2, r_floor) / v;
  sum->weighted = sum->weighted + p * a;
  sum->weight += a;
}

// Eq. (18): one other particle q (adaptive weight w_q = 1 / I(c_q)) near particle x.
// r2_min: the smallest squared distance from x among its particle neighbours.
VPR_HD inline void awlop_add_repulsion(AwlopSum* sum, Vec3d x, Vec3d q, double w, double r2_min, double inv_h2,
                                       double r_floor) {
  const Vec3d d = x - q;
  const double r2 = norm2(d);
  const double b = w * awlop_theta2_shifted(r2, r2_min, inv_h2) * awlop_inv_distance(r2, r_floor);
  sum->weighted = sum->weighted + d * b;
  sum->weight += b;
}

// Eq. (17): x_i <- A_i + mu R_i. An empty sum contributes nothing: no input
// neighbour leaves the particle where it is, no particle neighbour adds no push.
VPR_HD inline Vec3d awlop_update(Vec3d x, const AwlopSum& attraction, const AwlopSum& repulsion, double mu) {
  const Vec3d a = attraction.weight > 0 ? attraction.weighted * (1.0 / attraction.weight) : x;
  const Vec3d r = repulsion.weight > 0 ? repulsion.weighted * (1.0 / repulsion.weight) : Vec3d{};
  return a + r * mu;
}

// Input density weight v_j = 1 + sum_j' theta(|p_j - p_j'|) over p_j's nearest
// input neighbours (WLOP, Huang et al. 2009, Eq. 3): dense regions pull less.
// Accumulate theta over the neighbours into *sum starting from 1.
VPR_HD inline void awlop_add_density(double* sum, Vec3d p, Vec3d neighbour, double inv_h2) {
  *sum += awlop_theta2(norm2(neighbour - p), inv_h2);
}

}  // namespace vpr
