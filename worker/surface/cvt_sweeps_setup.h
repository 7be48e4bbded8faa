// Host-side setup shared by the CVT colour sweeps' two twins (cvt_sweeps.cpp,
// cvt_sweeps.cu): the input's checks and the fixed-point scales.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/status.h"
#include "surface/cvt_sweep_kernels.h"
#include "surface/cvt_sweeps.h"

namespace vpr {

// A surface's colouring takes about as many rounds as its longest chain of
// ever smaller ranks: a few dozen on a mesh; this many means a broken graph.
inline constexpr uint32_t kCvtMaxColourRounds = 4096;

inline Status check_cvt_sweep_input(const CvtSweepInput& in, const std::vector<uint32_t>& label) {
  if (!in.edges || !in.x || !in.y || !in.normal || !in.mass || !in.on_loop)
    return invalid_argument("CVT colour sweeps: missing element arrays");
  const size_t nv = in.edges->vertex_count();
  if (label.size() != nv)
    return invalid_argument("CVT colour sweeps: " + std::to_string(label.size()) + " labels for " + std::to_string(nv) +
                            " elements");
  if (nv >= kNoCell) return invalid_argument("CVT colour sweeps: too many elements");
  if (in.edges->faces.size() != in.edges->neighbor.size())
    return invalid_argument("CVT colour sweeps: edges without their face counts");
  for (uint32_t l : label)
    if (l != kNoCell && l >= in.cells)
      return invalid_argument("CVT colour sweeps: a label " + std::to_string(l) + " outside its " +
                              std::to_string(in.cells) + " cells");
  return Status::Ok();
}

// Each scale puts its quantity's largest possible total (every labelled
// element in one cell) at 2^61: sum m, sum m max|x_i|, sum m max|y_i|,
// sum m (unit normals).
inline CvtFixedScale cvt_fixed_scale(const CvtSweepInput& in, const std::vector<uint32_t>& label) {
  double m = 0, rx = 0, ry = 0;
  for (size_t v = 0; v < label.size(); ++v) {
    if (label[v] == kNoCell) continue;
    m += std::abs(in.mass[v]);
    rx = std::max({rx, std::abs(in.x[v].x), std::abs(in.x[v].y), std::abs(in.x[v].z)});
    ry = std::max({ry, std::abs(in.y[v].x), std::abs(in.y[v].y), std::abs(in.y[v].z)});
  }
  const double top = std::ldexp(1.0, 61);
  auto scale = [&](double total) { return total > 0 && std::isfinite(total) ? top / total : 1.0; };
  CvtFixedScale k;
  k.m = scale(m);
  k.s = scale(m * rx);
  k.t = scale(m * ry);
  k.n = scale(m);
  return k;
}

// A sweep's end: its E and moves recorded; true when the sweeps stop (as
// surface_cvt's do: nothing moved, or E fell by at most `tolerance` of itself).
inline bool cvt_sweeps_stop(double previous, double now, size_t moved, double tolerance, CvtSweepOutput* out) {
  out->energy.push_back(now);
  out->moves += moved;
  ++out->sweeps;
  out->converged = moved == 0 || previous - now <= tolerance * std::abs(previous);
  return out->converged;
}

}  // namespace vpr
