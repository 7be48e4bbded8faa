#include "surface/rim_band.h"

#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>

namespace vpr {
namespace {

// A cell coordinate in 21 bits. Clamping never moves two coordinates apart,
// so neighbours stay neighbours (far cells may share a key: the distance
// test still decides).
uint64_t axis_key(double x) {
  if (std::isnan(x)) return 1048576;
  const double c = std::clamp(std::floor(x), -1048576.0, 1048575.0);
  return uint64_t(int64_t(c) + 1048576);
}

double distance2_to_segment(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  const Vec3d d = b - a;
  const double len2 = dot(d, d);
  const double t = len2 > 0 ? std::clamp(dot(p - a, d) / len2, 0.0, 1.0) : 0.0;
  const Vec3d q = a + d * t;
  return dot(p - q, p - q);
}

Vec3d point(const std::vector<double>& positions, uint32_t i) {
  return {positions[3 * size_t(i)], positions[3 * size_t(i) + 1], positions[3 * size_t(i) + 2]};
}

// Points along a segment of this length: at most radius / 2 apart, both ends.
double points_along(double length, double radius) { return std::max(std::ceil(length / (0.5 * radius)), 1.0) + 1; }

}  // namespace

double RimBand::points_needed(const std::vector<double>& positions,
                              const std::vector<std::pair<uint32_t, uint32_t>>& segments, double radius) {
  if (!(radius > 0) || !std::isfinite(radius)) return 0;
  double total = 0;
  for (const auto& [i, j] : segments) total += points_along(norm(point(positions, j) - point(positions, i)), radius);
  return total;
}

RimBand::RimBand(const std::vector<double>& positions, const std::vector<std::pair<uint32_t, uint32_t>>& segments,
                 double radius) {
  if (segments.empty() || !(radius > 0) || !std::isfinite(radius)) return;
  radius2_ = radius * radius;
  inv_cell_ = 1 / (2 * radius);
  for (const auto& [i, j] : segments) {
    const Vec3d a = point(positions, i), b = point(positions, j);
    const uint32_t s = uint32_t(a_.size());
    a_.push_back(a);
    b_.push_back(b);
    // Points at most radius / 2 apart, both ends included: every point of
    // the segment is within radius / 4 of one, so a point within radius of
    // the segment is within 1.25 radius of one, less than a cell's side.
    const size_t n = size_t(std::min(points_along(norm(b - a), radius) - 1, 1e7));
    uint64_t last = UINT64_MAX;
    for (size_t k = 0; k <= n; ++k) {
      const uint64_t cell = cell_of(a + (b - a) * (double(k) / double(n)), 0, 0, 0);
      if (cell != last) entries_.push_back({cell, s});
      last = cell;
    }
  }
  tbb::parallel_sort(entries_.begin(), entries_.end());
  entries_.erase(std::unique(entries_.begin(), entries_.end(),
                             [](const Entry& x, const Entry& y) { return x.cell == y.cell && x.segment == y.segment; }),
                 entries_.end());
}

uint64_t RimBand::cell_of(const Vec3d& p, int dx, int dy, int dz) const {
  const uint64_t x = axis_key(p.x * inv_cell_), y = axis_key(p.y * inv_cell_), z = axis_key(p.z * inv_cell_);
  // A neighbour of a clamped coordinate may leave the 21 bits: such keys
  // are left out of the grid, so they match nothing (UINT64_MAX).
  const int64_t nx = int64_t(x) + dx, ny = int64_t(y) + dy, nz = int64_t(z) + dz;
  if (nx < 0 || ny < 0 || nz < 0 || nx >= (1 << 21) || ny >= (1 << 21) || nz >= (1 << 21)) return UINT64_MAX;
  return uint64_t(nx) << 42 | uint64_t(ny) << 21 | uint64_t(nz);
}

bool RimBand::near(const Vec3d& p) const {
  if (entries_.empty()) return false;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const uint64_t cell = cell_of(p, dx, dy, dz);
        if (cell == UINT64_MAX) continue;
        auto it = std::lower_bound(entries_.begin(), entries_.end(), Entry{cell, 0});
        for (; it != entries_.end() && it->cell == cell; ++it)
          if (distance2_to_segment(p, a_[it->segment], b_[it->segment]) <= radius2_) return true;
      }
  return false;
}

}  // namespace vpr
