// Least-squares offsets of a remeshed surface's vertices along their normals,
// so that its triangles fit the input surface in L2 instead of interpolating it.
//
// A mesh whose vertices all lie on a curved surface makes every triangle a
// chord: on a convex patch the whole triangle lies inside, up to the sagitta
// h^2 / (8 R) for edge length h and radius R, and the mean distance is about
// half of that. Moving each vertex along its normal by the offset that
// minimizes the squared distance of the input's samples to the output (the
// L2-optimal approximation, Cohen-Steiner, Alliez and Desbrun 2004 measure
// the same error; Lindstrom 2000 places vertices by the same least squares
// of planes) centres the triangles on the surface: on a sphere the mean
// distance falls to about a half of the interpolating mesh's.
//
// The unknowns are one offset d_k per free vertex along its unit normal N_k.
// A sample p of the input (a face centroid, weight w its area) is matched to the output
// triangle t nearest to it among the triangles around its cell's vertices,
// at barycentric coordinates b; moving the vertices moves the triangle's
// point along t's normal n_t by sum_k b_k d_k (N_k . n_t), so the residual is
//   r(p) = n_t . (p - q) - sum_k b_k (N_k . n_t) d_k,
// and we minimize sum_p w r(p)^2 + lambda sum_k W_k d_k^2 (W_k: the weight of
// vertex k's samples), a sparse symmetric positive definite system solved
// by conjugate gradients (a sparse Cholesky factorization if they stall).
// Held vertices (input boundary, creases, corners) keep d = 0:
// they already sit on a line the input pins down, and moving them off it
// would round the feature. Each offset is bounded by a fraction of the
// vertex's mean edge length, and an offset that would turn one of its
// triangles by more than a right angle is dropped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "surface/offset_match.h"

namespace vpr {

struct OffsetFitOptions {
  bool enabled = true;
  // |d_k| <= this x the mean length of vertex k's edges. A sphere's
  // L2-optimal offset is about h^2 / (16 R) (half the sagitta), which stays
  // under 0.1 h while an edge spans less than 90 degrees of arc (h < 1.4 R).
  double max_offset_per_edge = 0.1;
  // lambda: Tikhonov weight that keeps a vertex with few samples (or samples
  // all on one side) near the surface; small next to the data term.
  double regularization = 1e-3;
  // Rounds of (match samples to triangles, solve); a second one picks up
  // samples whose nearest triangle changed, for twice the time and little
  // gain once the offsets are bounded.
  int rounds = 1;
  // The samples matched and summed on a device (offset_match.h), or empty
  // for the host's; a failure there leaves the host to fit (the same bits).
  OffsetSampleSource device_samples;
};

struct OffsetFitStats {
  size_t free_vertices = 0;    // vertices solved for
  size_t held_vertices = 0;    // boundary, crease and corner vertices (d = 0)
  size_t clamped = 0;          // offsets cut to the bound (last round)
  size_t dropped = 0;          // offsets dropped because they turned a triangle
  double rms_before = 0;       // weighted RMS distance of the samples to the mesh, position units
  double rms_after = 0;        // the same after the fit, by the linear model of the last round
  int device_rounds = 0;       // rounds whose samples the device matched and summed
  std::string device_failure;  // why the device did not, when it was asked to and failed
};

// surface: the (refined) input; label: per surface vertex, its cell (or
// UINT32_MAX). cell_of_vertex: per output vertex of *mesh, its cell. held:
// per output vertex, 1 where it must not move. Moves *mesh's vertices.
Status fit_offsets(const Mesh& surface, const std::vector<uint32_t>& label, const std::vector<uint32_t>& cell_of_vertex,
                   const std::vector<char>& held, const OffsetFitOptions& options, Mesh* mesh, OffsetFitStats* stats);

}  // namespace vpr
