// Peer: CGAL's isotropic remeshing (Botsch and Kobbelt 2004: split long edges,
// collapse short ones, flip towards valence 6, tangential smoothing), the
// uniform remesher a user would pick instead of vpremesh. It takes a target
// edge length, not a vertex count, so we search for the length that lands on
// the count.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include "peers.h"
#include "peers_internal.h"

namespace vpr::peers {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

constexpr double kDefaultSlope = -2.0;  // V ~ A / L^2 for a uniform mesh

// The soup as a CGAL polygon mesh; `note` gets what the repair had to do.
StatusOr<SurfaceMesh> to_surface_mesh(const Mesh& input, std::string* note) {
  std::vector<Kernel::Point_3> points(input.vertex_count());
  for (size_t v = 0; v < points.size(); ++v)
    points[v] = {input.positions[3 * v], input.positions[3 * v + 1], input.positions[3 * v + 2]};
  std::vector<std::vector<size_t>> polygons(input.face_count());
  for (size_t f = 0; f < polygons.size(); ++f)
    polygons[f] = {input.indices[3 * f], input.indices[3 * f + 1], input.indices[3 * f + 2]};
  PMP::repair_polygon_soup(points, polygons);  // equal points merged; degenerate and duplicate faces removed
  if (polygons.empty()) return invalid_argument("CGAL isotropic: no face is left after removing degenerate ones");
  const size_t before = points.size();
  // Splits vertices where the faces around them do not form one fan
  // (returns false when it had to); an edge with three or more faces is cut
  // into separate sheets the same way.
  if (!PMP::orient_polygon_soup(points, polygons))
    *note = "split " + std::to_string(points.size() - before) + " non-manifold vertices; ";
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons))
    return invalid_argument(
        "CGAL isotropic: the input is not a 2-manifold and could not be made one by splitting its non-manifold "
        "vertices; isotropic remeshing needs a polygon mesh");
  SurfaceMesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  return mesh;
}

Mesh to_mesh(SurfaceMesh& sm) {
  sm.collect_garbage();
  std::vector<float> positions;
  positions.reserve(3 * sm.number_of_vertices());
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    positions.insert(positions.end(), {float(p.x()), float(p.y()), float(p.z())});
  }
  std::vector<uint32_t> indices;
  indices.reserve(3 * sm.number_of_faces());
  for (auto f : sm.faces())
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) indices.push_back(uint32_t(v.idx()));
  return compact(positions, indices);
}

}  // namespace

StatusOr<PeerResult> cgal_isotropic_remesh(const Mesh& input, uint32_t target_vertices,
                                           const IsotropicOptions& options) {
  if (Status s = check_input(input, target_vertices, "CGAL isotropic"); !s.ok()) return s;
  if (options.iterations < 1 || options.max_runs < 1 || !(options.tolerance >= 0))
    return invalid_argument("CGAL isotropic: iterations and max_runs must be at least 1, tolerance non-negative");
  const auto start = Clock::now();
  PeerResult result;
  try {
    auto base = to_surface_mesh(input, &result.note);
    if (!base.ok()) return base.status();
    const double area = PMP::area(*base);
    if (!(area > 0)) return invalid_argument("CGAL isotropic: the repaired mesh has zero area");

    // Search on x = log L for y = log V = log target.
    const double goal = std::log(double(target_vertices));
    double x = 0.5 * std::log(2.0 * area / (std::sqrt(3.0) * target_vertices));
    double prev_x = 0, prev_y = 0;
    double best_miss = INFINITY, best_length = 0, core_ms = 0;
    SurfaceMesh best;
    int runs = 0;
    for (; runs < options.max_runs; ++runs) {
      SurfaceMesh mesh = *base;
      const auto run_start = Clock::now();
      PMP::isotropic_remeshing(faces(mesh), std::exp(x), mesh,
                               CGAL::parameters::number_of_iterations(options.iterations));
      core_ms += ms_since(run_start);
      const double v = double(mesh.number_of_vertices());
      const double miss = std::abs(v / target_vertices - 1);
      if (miss < best_miss) {
        best_miss = miss;
        best_length = std::exp(x);
        best = std::move(mesh);
      }
      if (miss <= options.tolerance || v < 3) break;
      const double y = std::log(v);
      double slope = kDefaultSlope;
      if (runs > 0 && x != prev_x) {
        const double measured = (y - prev_y) / (x - prev_x);
        if (std::isfinite(measured) && measured < -0.5 && measured > -8) slope = measured;
      }
      prev_x = x;
      prev_y = y;
      // A step of at most a factor 2 in L per run.
      x += std::clamp((goal - y) / slope, -std::log(2.0), std::log(2.0));
    }
    result.core_ms = core_ms;
    result.mesh = to_mesh(best);
    result.mesh.origin = input.origin;  // positions stay in the input's frame
    result.mesh.scale = input.scale;
    char note[200];
    std::snprintf(note, sizeof note, "edge length %.4g (%.3g of the bbox diagonal) after %d run%s, %+.2f%% vertices",
                  best_length, best_length / bounding_box(input).diagonal(), std::min(runs + 1, options.max_runs),
                  runs == 0 ? "" : "s", 100.0 * (double(result.mesh.vertex_count()) / target_vertices - 1));
    result.note += note;
  } catch (const std::exception& e) {
    return invalid_argument(std::string("CGAL isotropic: CGAL failed: ") + e.what());
  }
  result.ms = ms_since(start);
  return result;
}

}  // namespace vpr::peers
