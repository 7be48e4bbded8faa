// The particle distribution, optimized to convergence on the input surface:
// a discrete restricted centroidal Voronoi tessellation (Valette and
// Chassery 2004, "Approximated centroidal Voronoi diagrams for uniform
// polygonal mesh coarsening"). The refined input's vertices are the
// surface's elements, each with the mass rho_i A_i (A_i: a third of its
// faces' area, rho = D^2 from surface_density.h). A cluster of elements is a
// particle's Voronoi cell restricted to the surface; the particle sits at its
// cell's weighted centroid. The energy
//   E = sum_c sum_{i in c} m_i |x_i - centroid_c|^2
// (the CVT energy, discretized) is minimized by moving elements between
// neighbouring clusters, one at a time, each move only when it lowers E: E
// falls monotonically and the loop stops when a sweep lowers it by less than
// `tolerance` (relative) or moves nothing. Clusters grow over the mesh's
// edges, never through space, so the two sheets of a thin part, or two parts
// that touch, are never one cell; a move that would cut a cell in two is not
// taken.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

struct CvtOptions {
  uint64_t seed = 1;
  double tolerance = 1e-5;   // stop when a sweep lowers E by less than this fraction
  int max_sweeps = 300;
  uint32_t min_per_part = 4;  // clusters each connected part gets at least (a tetrahedron), target permitting
};

struct CvtStats {
  int sweeps = 0;
  bool converged = false;
  std::vector<double> energy;  // E after initialization, then after each sweep
  size_t moves = 0;
  size_t parts = 0;              // connected parts of the surface
  size_t parts_below_minimum = 0;  // parts that got fewer than min_per_part clusters (target too small)
};

// label: per element, its cluster in [0, count). mass: per element.
Status surface_cvt(const Mesh& mesh, const std::vector<double>& mass, uint32_t count, const CvtOptions& options,
                   std::vector<uint32_t>* label, CvtStats* stats);

// A third of each incident face's area, per vertex.
std::vector<double> vertex_areas(const Mesh& mesh);

}  // namespace vpr
