// Per-element math of stage 5 (Section IV-B, Eq. 7-16), shared by the CPU
// sampler and its GPU twin: every function is inline VPR_HD, in double, with
// bounded loops, so both devices compute the same values. (1M samples came out
// bit-identical on an H100 with and without --fmad=false; build the .cu with
// --fmad=false to guarantee it, since a contracted multiply-add may round
// differently.)
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/rng.h"
#include "core/vec3.h"

namespace vpr {

// Eq. (7-8): q = area * (I_a + I_b + I_c) / 3 for face f. positions: #V x 3;
// indices: #F x 3; importance: #V. The area is computed as face_areas() does.
VPR_HD inline double face_visual_quantity(const float* positions, const uint32_t* indices, const float* importance,
                                          size_t f) {
  const uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
  const Vec3d pa = load3d(positions, a), pb = load3d(positions, b), pc = load3d(positions, c);
  const double area = 0.5 * norm(cross(pb - pa, pc - pa));
  return area * ((double(importance[a]) + double(importance[b]) + double(importance[c])) / 3.0);
}

// Eq. (9) in fixed point, so that the counts do not depend on the order in
// which a device adds the quantities up. Each q_i becomes the integer
// Q_i = round(q_i / q_max * 2^52): exact and the same on every device (one
// IEEE division, a power-of-two scaling, an exact rounding). Their prefix sums
// P_i are exact 128-bit integers whatever the scan order, and
//   offsets[i] = round(target * P_i / T),  T = P_F,  round(x) = floor(x + 1/2)
// is evaluated exactly in 128-bit integers (T < F 2^52 and target < 2^32, so
// the numerator stays below 2^128 for F < 2^43). The quantization moves S_i by
// at most F 2^-53 target units (1e-5 for 10^6 faces and 10^5 samples, and only
// when one face dominates; typically far less).
using QuantitySum = unsigned __int128;
inline constexpr int kQuantityBits = 52;

// q in [0, q_max], q_max > 0 and finite: Q in [0, 2^52].
VPR_HD inline uint64_t quantize_quantity(double q, double q_max) {
  const double scaled = (q / q_max) * double(uint64_t(1) << kQuantityBits);
  return uint64_t(std::floor(scaled + 0.5));  // scaled <= 2^52: x + 1/2 is exact
}

VPR_HD inline double quantity_sum_to_double(QuantitySum x) {
  return double(uint64_t(x >> 64)) * 18446744073709551616.0 + double(uint64_t(x));
}

// round(target * prefix / total) = floor((2 target prefix + total) / (2 total))
// for 0 <= prefix <= total, total > 0: at most target, exactly target at
// prefix = total. A double estimate lands within one or two of the quotient;
// exact 128-bit products then settle it, which is cheaper than a 128-bit
// division on either device and gives the same integer whatever the estimate.
VPR_HD inline uint32_t rounded_offset(QuantitySum prefix, QuantitySum total, uint32_t target) {
  const QuantitySum numerator = prefix * (2u * uint64_t(target)) + total;
  const QuantitySum denominator = total * 2u;
  const double ratio = quantity_sum_to_double(prefix) / quantity_sum_to_double(total);
  const double estimate = std::floor(double(target) * ratio + 0.5);
  uint64_t q = estimate > 0.0 ? uint64_t(estimate < double(target) ? estimate : double(target)) : 0;
  while (q > 0 && QuantitySum(q) * denominator > numerator) --q;
  while (QuantitySum(q + 1) * denominator <= numerator) ++q;
  return uint32_t(q);
}

// The slice parametrisation of a triangle (A, B, C): s in [0, 1] sweeps from A
// to the edge BC, t in [0, 1] runs along the slice from AB to AC:
//   p = A + s ((1 - t)(B - A) + t (C - A)),  barycentric (1 - s, s (1 - t), s t).
// Its area element is proportional to s, so with the importance linearly
// interpolated from the corners the sample density in (s, t) is
//   s [(1 - s) I_a + s (1 - t) I_b + s t I_c].

// Eq. (14): the marginal CDF of s (unnormalised),
//   G(s) = I_a (s^2/2 - s^3/3) + m s^3/3,  m = (I_b + I_c) / 2.
VPR_HD inline double adaptive_marginal_cdf(double s, double ia, double m) {
  const double s2 = s * s, s3 = s2 * s;
  return ia * (s2 / 2.0 - s3 / 3.0) + m * (s3 / 3.0);
}

// Solves G(s) = r G(1) for s in [0, 1]. Newton's method from the uniform-density
// root sqrt(r), safeguarded by the bracket [lo, hi] that every evaluation
// narrows: a step that leaves the bracket (G' vanishes at s = 0) bisects
// instead. G is increasing for importances >= 0, so the root is unique and the
// bracket always holds it. At most 60 steps (bisection alone reaches 2^-60);
// Newton converges in about 5.
VPR_HD inline double adaptive_s_d(double r, double ia, double ib, double ic) {
  const double m = 0.5 * (ib + ic);
  const double total = adaptive_marginal_cdf(1.0, ia, m);
  if (!(total > 0.0)) return std::sqrt(r);  // all importances 0: fall back to uniform
  const double goal = r * total;
  double lo = 0.0, hi = 1.0, s = std::sqrt(r);
  for (int it = 0; it < 60; ++it) {
    const double f = adaptive_marginal_cdf(s, ia, m) - goal;
    if (f == 0.0) break;
    if (f < 0.0)
      lo = s;
    else
      hi = s;
    const double g = s * ((1.0 - s) * ia + s * m);  // G'(s)
    double next = g > 0.0 ? s - f / g : lo - 1.0;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == s || hi - lo <= 1e-15) break;
    s = next;
  }
  return s;
}

// Eq. (16): given s, t has the linear density a + b t on [0, 1] with
//   a = (1 - s) I_a + s I_b,  b = s (I_c - I_b),
// so H(t) = a t + b t^2 / 2 and H(t) = r H(1) is the quadratic
// (b/2) t^2 + a t - c = 0, c = r (a + b/2). Its root in [0, 1] in the form
// t = 2c / (a + sqrt(a^2 + 2 b c)) has no cancellation for b of either sign and
// reduces to c / a in the linear case b = 0 (I_b == I_c).
VPR_HD inline double adaptive_t_d(double r, double s, double ia, double ib, double ic) {
  const double a = (1.0 - s) * ia + s * ib;
  const double b = s * (ic - ib);
  const double total = a + 0.5 * b;
  if (!(total > 0.0)) return r;  // zero density on the slice: uniform
  const double c = r * total;
  const double disc = a * a + 2.0 * b * c;  // >= (a + b)^2 >= 0 up to rounding
  const double denom = a + std::sqrt(disc > 0.0 ? disc : 0.0);
  if (!(denom > 0.0)) return 0.0;  // a = 0 and c = 0
  const double t = 2.0 * c / denom;
  return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

// Float entry points of the two inverse CDFs (the contract in
// adaptive_sampling.h): r in [0, 1], importances >= 0; returns s or t in [0, 1].
VPR_HD inline float adaptive_s(float r, float ia, float ib, float ic) {
  return float(adaptive_s_d(r, ia, ib, ic));
}
VPR_HD inline float adaptive_t(float r, float s, float ia, float ib, float ic) {
  return float(adaptive_t_d(r, s, ia, ib, ic));
}

// Sample j of face f (Eq. 11-16). Two uniforms from Philox keyed by (seed, f),
// counter j. adaptive = false: uniform in area (s = sqrt(r1), t = r2);
// true: the inverse CDFs above. Writes the point (3 floats) and its importance
// interpolated barycentrically from the corners.
VPR_HD inline void sample_point(const float* positions, const uint32_t* indices, const float* importance, size_t f,
                                uint32_t j, uint64_t seed, bool adaptive, float* point, float* point_importance) {
  const uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
  const double ia = importance[a], ib = importance[b], ic = importance[c];
  const Philox4 bits = random4(seed, f, j);
  const double r1 = uniform01(bits.v[0]), r2 = uniform01(bits.v[1]);
  double s, t;
  if (adaptive) {
    s = adaptive_s_d(r1, ia, ib, ic);
    t = adaptive_t_d(r2, s, ia, ib, ic);
  } else {
    s = std::sqrt(r1);
    t = r2;
  }
  // A convex combination in double, rounded once: the float point stays in the
  // triangle up to that rounding.
  const double wa = 1.0 - s, wb = s * (1.0 - t), wc = s * t;
  const Vec3d pa = load3d(positions, a), pb = load3d(positions, b), pc = load3d(positions, c);
  const Vec3d p = pa * wa + pb * wb + pc * wc;
  point[0] = float(p.x);
  point[1] = float(p.y);
  point[2] = float(p.z);
  *point_importance = float(wa * ia + wb * ib + wc * ic);
}

}  // namespace vpr
