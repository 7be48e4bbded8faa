// Jacobi passes of per-vertex vectors over a mesh's edges: each vertex's
// vector becomes half its own plus half its neighbours' mean (a vertex with
// no neighbour keeps its own). The CVT's anisotropic offsets smooth the
// normals so (surface_cvt.cpp): about half a cell's width of passes, 20 on a
// default job, the largest of the CVT's host steps that a GPU does at once.
// Each pass reads only the last, so both twins give the same bits on any
// thread count (the .cu is compiled without FMA contraction).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "core/vec3.h"
#include "surface/mesh_edges.h"

namespace vpr {

// One vertex's pass: its row summed in order, then weighted.
VPR_HD inline Vec3d smoothed_vector(const uint32_t* offset, const uint32_t* neighbor, const Vec3d* now, uint32_t v) {
  const uint32_t degree = offset[v + 1] - offset[v];
  if (degree == 0) return now[v];
  Vec3d sum{0, 0, 0};
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) sum = sum + now[neighbor[i]];
  return now[v] * 0.5 + sum * (0.5 / double(degree));
}

// The same for a float per vertex (the density, surface_density.h: 16
// passes on every default job), its row summed in double.
VPR_HD inline float smoothed_scalar(const uint32_t* offset, const uint32_t* neighbor, const float* now, uint32_t v) {
  const uint32_t degree = offset[v + 1] - offset[v];
  if (degree == 0) return now[v];
  double sum = 0;
  for (uint32_t i = offset[v]; i < offset[v + 1]; ++i) sum += now[neighbor[i]];
  return float(0.5 * now[v] + 0.5 * sum / double(degree));
}

// values: one per vertex of `edges`, smoothed in place.
using EdgeSmoothing = std::function<Status(const MeshEdges& edges, int passes, std::vector<Vec3d>* values)>;
using ScalarEdgeSmoothing = std::function<Status(const MeshEdges& edges, int passes, std::vector<float>* values)>;

namespace cpu {
Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<Vec3d>* values);
Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<float>* values);
}  // namespace cpu

// GPU twins, built when VPR_HAVE_CUDA (edge_smoothing.cu): the same bits.
namespace cuda {
Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<Vec3d>* values, const ExecContext& ctx);
Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<float>* values, const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
