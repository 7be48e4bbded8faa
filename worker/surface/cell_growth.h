// The CVT's cells grown from their seeds over the edges to the nearest seed
// (graph distance on edge lengths), so that every cell starts connected
// (surface_cvt.cpp). In rounds (Bellman-Ford on a moving front): each element
// next to one that improved last round takes its best neighbour's distance
// plus the edge, and its cell, if that is shorter; every round reads only the
// last, so any thread count and either twin give the same cells. Two passes:
// first a cell takes only elements facing within 100 degrees of its seed
// (kCvtFacing), so that no cell starts round a thin part or over the rim of a
// thin plate; then, from where that stopped, the elements no cell could take
// (a part with a seed on one side only) go to the nearest cell whatever way
// they face, the first pass's cells settled.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "core/vec3.h"
#include "surface/cvt_sweep_kernels.h"
#include "surface/mesh_edges.h"

namespace vpr {

struct CellGrowthInput {
  const MeshEdges* edges = nullptr;
  const Vec3d* x = nullptr;                      // per element
  const Vec3d* normal = nullptr;                 // per element, unit
  const std::vector<uint32_t>* seeds = nullptr;  // cell c's seed element
};

// One element's best neighbour in a round: (distance, cell), or its own
// distance and kNoCell (cvt_sweep_kernels.h) when none is shorter. dist and
// label as the round began; facing: the first pass's rule.
VPR_HD inline void cell_growth_best(const uint32_t* offset, const uint32_t* neighbor, const Vec3d* x,
                                    const Vec3d* normal, const uint32_t* seeds, const double* dist,
                                    const uint32_t* label, bool facing, uint32_t v, double* best_dist,
                                    uint32_t* best_cell) {
  double bd = dist[v];
  uint32_t bc = kNoCell;
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) {
    const uint32_t w = neighbor[i];
    if (facing && label[w] != kNoCell && dot(normal[v], normal[seeds[label[w]]]) < kCvtFacing) continue;
    const double nd = dist[w] + norm(x[w] - x[v]);
    if (nd < bd) bd = nd, bc = label[w];
  }
  *best_dist = bd;
  *best_cell = bc;
}

// label: the seeds' cells set (label[seeds[c]] == c), every other element
// kNoCell; on return each element reached holds its cell.
using CellGrowth = std::function<Status(const CellGrowthInput&, std::vector<uint32_t>* label)>;

// The input's checks, shared by both twins.
Status check_cell_growth_input(const CellGrowthInput& input, const std::vector<uint32_t>& label);

namespace cpu {
Status grow_cells(const CellGrowthInput& input, std::vector<uint32_t>* label);
}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (cell_growth.cu): the same cells.
namespace cuda {
Status grow_cells(const CellGrowthInput& input, std::vector<uint32_t>* label, const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
