// Which points lie near a surface's open edges (its rims and the feet of its
// fins): within `radius` of one of the given segments. The refinement
// (surface_refine.h) keeps its elements finer there, where the dual needs
// more of them per cell to keep a rim cell between two others, and coarser
// elsewhere, where the CVT does as well with fewer (docs/pipeline.md, "5-7").
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/vec3.h"

namespace vpr {

class RimBand {
 public:
  RimBand() = default;  // no segments: near() is always false
  // positions: x, y, z per vertex; segments: pairs of vertex indices into
  // them; radius > 0. Each segment is listed in the grid cells (of side
  // 2 radius) of points along it at most radius / 2 apart, so a point within
  // radius of it has one of them in its own cell or a neighbouring one.
  RimBand(const std::vector<double>& positions, const std::vector<std::pair<uint32_t, uint32_t>>& segments,
          double radius);

  // How many grid entries the constructor would list for these segments (at
  // most; each segment's points in distinct cells count once): callers with
  // untrusted input bound it before building.
  static double points_needed(const std::vector<double>& positions,
                              const std::vector<std::pair<uint32_t, uint32_t>>& segments, double radius);

  bool empty() const { return entries_.empty(); }
  // Whether p lies within radius of a segment (the distance to the segment,
  // not to its ends: a long rim edge counts along its whole length).
  bool near(const Vec3d& p) const;

 private:
  struct Entry {
    uint64_t cell;
    uint32_t segment;
    bool operator<(const Entry& o) const { return cell != o.cell ? cell < o.cell : segment < o.segment; }
  };
  uint64_t cell_of(const Vec3d& p, int dx, int dy, int dz) const;

  std::vector<Vec3d> a_, b_;  // per segment, its ends
  std::vector<Entry> entries_;  // sorted by cell
  double radius2_ = 0, inv_cell_ = 0;
};

}  // namespace vpr
