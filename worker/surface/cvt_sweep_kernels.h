// The arithmetic of the CVT's colour sweeps (cvt_sweeps.h), shared by the CPU
// reference (cvt_sweeps.cpp) and the GPU twin (cvt_sweeps.cu): no allocation,
// no library call beyond <cmath>, every function VPR_HD, so both give the same
// bits (the .cu is compiled without FMA contraction).
//
// The cells' sums are kept in 64-bit fixed point: a move adds and subtracts
// integers, which commute, so the sums after a round do not depend on the
// order in which its moves land (atomics on the GPU, any thread on the CPU).
#pragma once

#include <cmath>
#include <cstdint>

#include "core/vec3.h"

namespace vpr {

inline constexpr uint32_t kNoCell = 0xFFFFFFFFu;
// A cell holds no element whose normal is more than 100 degrees from the way
// the cell faces (surface_cvt.cpp says why): cos 100 degrees.
inline constexpr double kCvtFacing = -0.17364817766693033;
// Sums per cell in fixed point: m, m x (3), m a n (3: the R^6 half), m n (3).
inline constexpr int kCvtSums = 10;

// value * scale -> integer: each scale puts the largest total (all elements
// in one cell) at 2^61, so no cell's sum can overflow.
struct CvtFixedScale {
  double m = 1, s = 1, t = 1, n = 1;
};

VPR_HD inline long long cvt_fixed(double value, double scale) {
  return llrint(value * scale);
}

// Element v's ten contributions, in the order of kCvtSums.
VPR_HD inline void cvt_contribution(double m, Vec3d x, Vec3d y, Vec3d n, const CvtFixedScale& k, long long* out) {
  out[0] = cvt_fixed(m, k.m);
  out[1] = cvt_fixed(m * x.x, k.s), out[2] = cvt_fixed(m * x.y, k.s), out[3] = cvt_fixed(m * x.z, k.s);
  out[4] = cvt_fixed(m * y.x, k.t), out[5] = cvt_fixed(m * y.y, k.t), out[6] = cvt_fixed(m * y.z, k.t);
  out[7] = cvt_fixed(m * n.x, k.n), out[8] = cvt_fixed(m * n.y, k.n), out[9] = cvt_fixed(m * n.z, k.n);
}

// A cell's (or an element's) sums back in doubles.
struct CvtSums {
  double m = 0;
  Vec3d s, t, n;
};

VPR_HD inline CvtSums cvt_sums(const long long* f, const CvtFixedScale& k) {
  CvtSums c;
  c.m = double(f[0]) / k.m;
  c.s = {double(f[1]) / k.s, double(f[2]) / k.s, double(f[3]) / k.s};
  c.t = {double(f[4]) / k.t, double(f[5]) / k.t, double(f[6]) / k.t};
  c.n = {double(f[7]) / k.n, double(f[8]) / k.n, double(f[9]) / k.n};
  return c;
}

// -|(s, t)|^2 / m: a cell's share of E = sum_c sum_{i in c} m_i |(x_i, a n_i) - centroid_c|^2,
// less sum m |(x, a n)|^2, which no move changes.
VPR_HD inline double cvt_cell_energy(const CvtSums& c) {
  return c.m > 0 ? -(dot(c.s, c.s) + dot(c.t, c.t)) / c.m : 0.0;
}

// How much E falls when element e (its sums) moves from cell a (`a_size`
// elements) to cell b; 0 when a would be left empty.
VPR_HD inline double cvt_move_gain(const CvtSums& a, uint32_t a_size, const CvtSums& b, const CvtSums& e) {
  if (a_size <= 1 || !(a.m - e.m > 0)) return 0.0;
  const Vec3d sa = a.s - e.s, sb = b.s + e.s, ta = a.t - e.t, tb = b.t + e.t;
  const double after = -(dot(sa, sa) + dot(ta, ta)) / (a.m - e.m) - (dot(sb, sb) + dot(tb, tb)) / (b.m + e.m);
  return cvt_cell_energy(a) + cvt_cell_energy(b) - after;
}

// Is b adjacent to a (rows sorted ascending)?
VPR_HD inline bool cvt_adjacent(const uint32_t* offset, const uint32_t* neighbor, uint32_t a, uint32_t b) {
  uint32_t lo = offset[a], hi = offset[a + 1];
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (neighbor[mid] < b)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < offset[a + 1] && neighbor[lo] == b;
}

// How many groups v's neighbours in cell c form, joined by the edges among
// v's neighbours (64 or more neighbours in c: reported as 2, which forbids
// the move). Taking v out of c keeps c connected when this is 1; putting v
// into c keeps c a disk (no ring closes round a hole or a limb) when this is
// 1. A local test, conservative on a manifold: with both, a move is a
// simple-point move of digital topology. Two moves at once stay simple when
// their elements are not neighbours (neither test reads the other element).
VPR_HD inline uint32_t cvt_neighbour_groups(const uint32_t* offset, const uint32_t* neighbor, const uint32_t* label,
                                            uint32_t v, uint32_t c) {
  uint32_t ring[64];
  uint32_t n = 0;
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i)
    if (label[neighbor[i]] == c) {
      if (n == 64) return 2;
      ring[n++] = neighbor[i];
    }
  if (n <= 1) return n;
  uint8_t parent[64];
  for (uint32_t i = 0; i < n; ++i) parent[i] = uint8_t(i);
  uint32_t groups = n;
  for (uint32_t i = 0; i < n; ++i)
    for (uint32_t j = i + 1; j < n; ++j)
      if (cvt_adjacent(offset, neighbor, ring[i], ring[j])) {
        uint32_t a = i, b = j;
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        while (parent[b] != b) b = parent[b] = parent[parent[b]];
        if (a != b) {
          parent[a] = uint8_t(b);
          --groups;
        }
      }
  return groups;
}

// An element's place in the colouring (Jones and Plassmann 1993): it takes a
// colour in the first round in which it outranks every neighbour not yet
// coloured; ranks by a hash of the index, ties by the index.
VPR_HD inline uint64_t cvt_colour_rank(uint32_t v) {
  uint64_t h = uint64_t(v) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return (h & 0xFFFFFFFF00000000ull) | v;
}

inline constexpr uint8_t kUncoloured = 0xFF;
// Colours 0..63, and 64 for an element every colour is taken around.
inline constexpr uint32_t kCvtColourSlots = 65;

// One round for element v: its colour (the smallest its coloured neighbours
// do not use) when it outranks every neighbour uncoloured before the round,
// else kUncoloured. `round_of[w]` < round: w was coloured in an earlier round.
VPR_HD inline uint8_t cvt_colour_in_round(const uint32_t* offset, const uint32_t* neighbor, const uint8_t* colour,
                                          const uint32_t* round_of, uint32_t round, uint32_t v) {
  const uint64_t mine = cvt_colour_rank(v);
  uint64_t used = 0;  // colours 0..63 of neighbours coloured before
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) {
    const uint32_t w = neighbor[i];
    if (round_of[w] < round) {
      if (colour[w] < 64) used |= uint64_t(1) << colour[w];
    } else if (cvt_colour_rank(w) > mine) {
      return kUncoloured;
    }
  }
  uint8_t c = 0;
  while (c < 64 && (used >> c & 1)) ++c;
  return c;  // 64: every colour taken (degree 64 or more): the colour sweeps never move it
}

// Whether some neighbour of v lies in another cell: else cvt_best_move finds
// no cell for v (most elements, inside their cells), and a round need not
// weigh v's move at all.
VPR_HD inline bool cvt_on_cell_edge(const uint32_t* offset, const uint32_t* neighbor, const uint32_t* label,
                                    uint32_t v) {
  const uint32_t a = label[v];
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) {
    const uint32_t b = label[neighbor[i]];
    if (b != a && b != kNoCell) return true;
  }
  return false;
}

// Element v's move this round: the neighbouring cell with the largest gain
// over `threshold` that v may join (facing its way, both cells kept disks),
// ties to the lower cell id; kNoCell when none. An element on a boundary
// loop (on_loop) moves only along it: from a cell that keeps one of its
// neighbours along the loop to the cell of another, so no cell gains or
// loses a loop and every loop keeps its cells (surface_cvt's loop rules),
// whatever else moves in the round (those neighbours, being neighbours, do
// not move in it). faces: per entry of the rows, the faces of that edge.
VPR_HD inline uint32_t cvt_best_move(const uint32_t* offset, const uint32_t* neighbor, const uint32_t* faces,
                                     const uint32_t* label, const long long* sums, const uint32_t* size,
                                     const CvtFixedScale& k, const CvtSums& e, Vec3d normal, bool on_loop, uint32_t v,
                                     double threshold) {
  const uint32_t a = label[v];
  if (a == kNoCell || size[a] <= 1) return kNoCell;
  if (on_loop) {
    bool kept = false;
    for (uint32_t i = offset[v]; i < offset[v + 1] && !kept; ++i) kept = faces[i] == 1 && label[neighbor[i]] == a;
    if (!kept) return kNoCell;
  }
  const CvtSums ca = cvt_sums(sums + size_t(a) * kCvtSums, k);
  uint32_t rejected[8];
  uint32_t rejections = 0;
  for (;;) {
    uint32_t best = kNoCell;
    double best_gain = threshold;
    for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) {
      const uint32_t b = label[neighbor[i]];
      if (b == a || b == kNoCell || (on_loop && faces[i] != 1)) continue;
      bool seen = b == best;
      for (uint32_t r = 0; r < rejections && !seen; ++r) seen = rejected[r] == b;
      if (seen) continue;
      const double g = cvt_move_gain(ca, size[a], cvt_sums(sums + size_t(b) * kCvtSums, k), e);
      if (g > best_gain || (g == best_gain && best != kNoCell && b < best)) best = b, best_gain = g;
    }
    if (best == kNoCell) return kNoCell;
    const CvtSums cb = cvt_sums(sums + size_t(best) * kCvtSums, k);
    if (dot(normal, cb.n) >= kCvtFacing * norm(cb.n) && cvt_neighbour_groups(offset, neighbor, label, v, a) == 1 &&
        cvt_neighbour_groups(offset, neighbor, label, v, best) == 1)
      return best;
    if (rejections == 8) return kNoCell;
    rejected[rejections++] = best;
  }
}

// E less its constant, summed as the GPU's one-block reduction sums it:
// 1024 partial sums (cell c into partial c mod 1024, in ascending c), then
// halved pairwise. cell_energy(c) gives cell c's term.
inline constexpr uint32_t kCvtEnergyLanes = 1024;

}  // namespace vpr
