// Peer methods: what a user would run instead of vpremesh to get a mesh of a
// given vertex count. Each takes any mesh or soup that passes validate_mesh and
// a target vertex count, and returns the result with its wall time, so that
// `vpremesh compare`, the benchmark and the quality docs measure them alike.
//   openmesh_quadric       OpenMesh's DecimaterT + ModQuadricT (Garland-Heckbert QEM)
//   meshopt_simplify       meshoptimizer's edge-collapse simplifier (quadric error)
//   cgal_isotropic_remesh  CGAL's Polygon_mesh_processing::isotropic_remeshing
// None of them is perception-guided; they are the baselines of Table I.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"

namespace vpr::peers {

struct PeerResult {
  Mesh mesh;           // compact: every vertex is referenced by a face
  double ms = 0;       // wall time of the whole call: conversion in, the method, conversion out
  double core_ms = 0;  // wall time of the library's algorithm alone (what the benchmark reports)
  std::string note;    // what the method had to do or could not do, "" when nothing to say
};

// OpenMesh's quadric decimater to target_vertices (exact unless the mesh runs
// out of legal collapses). Corners at exactly the same position are welded
// first. OpenMesh needs an oriented manifold: faces it refuses (complex edges,
// orientation opposite to a neighbour's) are left out and counted in `note`.
// INVALID_ARGUMENT when the mesh fails validate_mesh, target_vertices is 0, or
// OpenMesh accepts no face.
StatusOr<PeerResult> openmesh_quadric(const Mesh& input, uint32_t target_vertices);

// meshoptimizer's meshopt_simplify. Corners at exactly the same position are
// welded first (meshoptimizer never moves across a seam), the target index count
// is the welded mesh's index count scaled by target / welded vertex count, and
// when the result misses the target by more than 1% the index target is
// rescaled and the simplification rerun from the input (at most 4 runs). It
// may stop short of the target where no collapse is legal; `note` reports the
// vertex count it lands on. target_error is unbounded (1.0 = the whole mesh).
StatusOr<PeerResult> meshopt_simplify(const Mesh& input, uint32_t target_vertices);

struct IsotropicOptions {
  int iterations = 3;       // split/collapse/flip/smooth rounds of one remeshing run (CGAL's default is 1)
  int max_runs = 6;         // remeshing runs spent searching for the edge length
  double tolerance = 0.02;  // stop when |V - target| <= tolerance * target
};

// CGAL's isotropic remeshing with the target edge length L chosen to land on
// target_vertices: L0 from the area (an equilateral mesh of V vertices and 2V
// faces covers A = V sqrt(3)/2 L^2), then secant steps on log V(log L) (slope
// -2 until two runs give a measured one); each run starts from the input. The
// best run is returned; `note` gives L, the runs and the relative miss.
// Unlike the other two peers, this one repairs orientation: the input is
// first repaired as a soup (duplicate and degenerate faces
// removed, orientation made consistent; non-manifold vertices are split).
// INVALID_ARGUMENT with the reason when it still cannot become a
// polygon mesh (e.g. an edge shared by three faces that splitting cannot fix)
// or when CGAL throws.
StatusOr<PeerResult> cgal_isotropic_remesh(const Mesh& input, uint32_t target_vertices,
                                           const IsotropicOptions& options = {});

// Every peer by name, in table order: "OpenMesh QEM", "meshoptimizer",
// "CGAL isotropic".
struct Peer {
  std::string name;
  std::function<StatusOr<PeerResult>(const Mesh&, uint32_t)> run;
};
const std::vector<Peer>& all_peers();

}  // namespace vpr::peers
