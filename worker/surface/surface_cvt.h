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
// that touch, are never one cell; a move that would cut a cell in two, or
// close it into a ring, is not taken, so cells stay disks. Each boundary loop
// keeps at least min_per_loop cells and no cell meets two loops. A cell whose
// dual vertex would still be non-manifold (a thin part or handle) is split,
// its elements weighted up so the cells there stay small, and as many flat
// cells elsewhere are merged away; the sweeps then go on.
// In parallel with one result on any thread count: the cells grow from their
// seeds in rounds that read only the last round, and each sweep visits slabs
// of the surface at once (even ones, then odd ones, each in element order on
// one thread, moving only elements and cells no other running slab touches),
// the rest in a last pass on one thread.
#pragma once

#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"
#include "surface/cell_growth.h"
#include "surface/cvt_sweeps.h"
#include "surface/edge_smoothing.h"
#include "surface/mesh_edges.h"

namespace vpr {

// What surface_cvt makes of the surface alone, kept for later runs on the
// same surface (a visual target's warm tries: pipeline.cpp): the elements'
// unit normals, and the anisotropic offsets of the last (smoothing passes,
// taper, anisotropy) asked, which depend on the count only through those
// two whole numbers (a warm try 2-15% from its source's count mostly asks
// the same). Filled by the first run, read by the next: the same bits as
// making them again.
struct CvtSurfaceCache {
  std::mutex mutex;  // held by a run while it reads or fills the cache
  std::vector<Vec3d> normal;
  int passes = -1, taper = -1;
  double anisotropy = -1;
  std::vector<Vec3d> offsets;
};

struct CvtOptions {
  uint64_t seed = 1;
  // Stop when a sweep lowers E by less than this fraction. From stratified
  // seeds E falls geometrically: within 0.1% of its end after about 8 sweeps.
  // 1e-4 against 1e-5 on the referee's 30 cases: 23% fewer sweeps, final E
  // within 0.22% (median 0), SSIM, FLIP, Hausdorff distance, angles and topology the same
  // (docs/quality.md, "Stratified seeds").
  double tolerance = 1e-4;
  int max_sweeps = 300;
  uint32_t min_per_part = 4;  // clusters each connected part gets at least (a tetrahedron), target permitting
  // Share of the target split equally between connected parts, the rest by
  // mass: every part gets at least count * equal_part_share / parts clusters
  // whatever its size, so small parts keep their shape (docs/pipeline.md).
  double equal_part_share = 0.25;
  // Per job: pairs of elements whose parts count as one in that equal share
  // (a vertex and its copy where refine_surface split a pinch: a table's
  // legs, welded to its top at one vertex each, share the table's equal
  // share instead of drawing one each from the rest).
  std::vector<std::pair<uint32_t, uint32_t>> joined_elements;
  uint32_t min_per_loop = 3;  // clusters on each boundary loop at least (fewer and the dual closes it), quota permitting
  // Cells whose dual vertex would be non-manifold are split, in up to this
  // many rounds, up to max_split_fraction x count splits in all; as many
  // cells away from them are merged into their neighbours, so the count
  // stays. Measured: boot.obj at 2,000 needs 6%; at 1,000 it needs 16% (with
  // 10% it came back in 5 parts), and fish.obj at 100 12%. No shared model at
  // the referee's 30 targets reaches 10%. A dumbbell whose neck (1% of its
  // length wide) holds 4% of the area needs about 40% and 9 rounds at 100
  // vertices (a quarter and 8 rounds left it in three pieces); where even
  // half the count is not enough (a wire ring 2% thick at 300), merges fall
  // short and the count rises above the target, which the stage note says.
  int topology_rounds = 16;
  double max_split_fraction = 0.5;
  double split_mass_factor = 4;  // a split cell's elements weigh this much more (cells there half as wide)
  // Length a by which each element's unit normal is scaled to make its
  // position in R^6, (x, a n) (Levy and Bonneel 2012, "Variational
  // anisotropic surface meshing with Voronoi parallel linear enumeration"):
  // cells stretch along the directions in which the normal turns least. 0:
  // the isotropic CVT.
  double anisotropy = 0;
  // A warm start instead of seeds: the labels of an earlier run on this
  // surface (a visual target's try at a nearby count: pipeline.cpp). With
  // more cells than `count` the surplus is merged away, the cheapest merges
  // in E first; with fewer, the cells holding the most of E are cut in two
  // until the count is reached. The sweeps and the topology step go on from
  // there: a few sweeps where a cold start takes a dozen. Null: the seeds.
  const std::vector<uint32_t>* start_label = nullptr;
  // The surface's normals and offsets from an earlier run on this surface,
  // or filled for a later one (null: made and dropped).
  CvtSurfaceCache* surface_cache = nullptr;
  // The mesh's corners by vertex (mesh_edges, surface_refine's RefinedSurface),
  // or null or not built: the vertex normals then read every face per range
  // of vertices. The same normals either way.
  const VertexCorners* corners = nullptr;
  // Sweeps in colour rounds to run before each run of the sweeps (cvt_sweeps.h;
  // the pipeline passes the GPU twin), to a quarter of `tolerance` and with
  // max_sweeps of their own: they make the bulk of the moves, and the sweeps
  // finish from where they stop. Empty: the sweeps alone.
  CvtDeviceSweeps device_sweeps;
  // The anisotropic offsets' smoothing passes on another device
  // (edge_smoothing.h; the pipeline passes the GPU twin with the sweeps'):
  // the same bits. Empty: on the CPU.
  EdgeSmoothing device_smoothing;
  // The cells' growth from their seeds on another device (cell_growth.h; the
  // pipeline passes the GPU twin with the sweeps'): the same cells. Empty: on
  // the CPU.
  CellGrowth device_growth;
};

struct CvtStats {
  int sweeps = 0;  // device_sweeps among them
  bool converged = false;
  std::vector<double> energy;  // E after initialization, then after each sweep
  size_t moves = 0;
  size_t parts = 0;              // connected parts of the surface
  size_t parts_below_minimum = 0;  // parts that got fewer than min_per_part clusters (target too small)
  uint32_t clusters = 0;          // clusters in the result: count, or more where merges fell short
  size_t cells_split = 0;         // cells split for the dual's topology
  size_t cells_merged = 0;        // cells merged away to make up for the splits
  size_t defective_cells = 0;     // cells whose dual vertex is still non-manifold
  size_t warm_merged = 0;         // a warm start's cells merged away to reach count
  size_t warm_split = 0;          // a warm start's cells cut in two to reach count
  size_t device_sweeps = 0;       // of `sweeps`, those in colour rounds (CvtOptions::device_sweeps)
};

// label: per element, its cluster in [0, stats->clusters), at least count
// clusters (more where cells were split for topology). mass: per element.
Status surface_cvt(const Mesh& mesh, const std::vector<double>& mass, uint32_t count, const CvtOptions& options,
                   std::vector<uint32_t>* label, CvtStats* stats);
// The same with the mesh's edges already built (mesh_edges(mesh)).
Status surface_cvt(const Mesh& mesh, const MeshEdges& edges, const std::vector<double>& mass, uint32_t count,
                   const CvtOptions& options, std::vector<uint32_t>* label, CvtStats* stats);

// A third of each incident face's area, per vertex, summed in face order.
// corners: the mesh's corners by vertex where built (each vertex reads its
// own faces only, where without them every thread reads every face); the
// same sums either way.
std::vector<double> vertex_areas(const Mesh& mesh, const VertexCorners* corners = nullptr);

}  // namespace vpr
