// Edge flips on a triangle mesh: the connectivity changes, the vertices stay.
// The surface back half (cluster_mesh.h) runs them after the dual of the CVT
// cells: towards the Delaunay triangulation, to put back crease edges the
// dual cut, and to remove caps (a corner almost on its opposite edge).
#pragma once

#include <Eigen/Dense>

#include <cstdint>
#include <memory>
#include <vector>

#include "core/mesh.h"

namespace vpr {

// cos(30 degrees): faces further apart than this meet at a crease.
constexpr double kCreaseCos = 0.8660254037844386;

// Each vertex's row of edges, which every run of flips needs (edge_flips.cpp)
// and brings up to date by its own flips: kept from one run to the next on
// one mesh, so that each run does not make them again (the dual's five runs
// made them five times). A run whose mesh has other faces than the rows were
// last brought up to date for (another mesh, or faces changed between the
// runs) makes them afresh, so a kept set never gives other flips than a new
// one.
class FlipRowsKept {
 public:
  FlipRowsKept();
  ~FlipRowsKept();
  struct Rows;
  std::unique_ptr<Rows> rows;
};

// Passes of Delaunay flips: an interior edge whose two opposite angles sum
// to more than pi is flipped, unless the flip would fold the surface, cross a
// crease (faces more than 30 degrees apart), or make an edge that exists
// already.
void delaunay_flips(Mesh* mesh, FlipRowsKept* kept = nullptr);

// Crease edges the dual missed, flipped back (see edge_flips.cpp): on_feature
// per vertex (a crease or corner cell's vertex), line per vertex (its crease
// direction; zero for a corner or a free vertex).
void restore_crease_edges(Mesh* mesh, const std::vector<char>& on_feature, const std::vector<Eigen::Vector3d>& line,
                          FlipRowsKept* kept = nullptr);

// Caps flipped away: a triangle with an angle over 150 degrees whose long
// edge's flip makes the pair's smallest angle larger (see edge_flips.cpp).
// Returns the number of flips.
size_t flip_caps(Mesh* mesh, FlipRowsKept* kept = nullptr);

}  // namespace vpr
