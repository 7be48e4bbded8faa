// Stage 7: mesh the optimized points. The paper uses Tight CoCone; we use CGAL's
// Advancing Front Surface Reconstruction (Cohen-Steiner and Da, 2004), which
// interpolates the points as Tight CoCone does, then repair its facets into an
// oriented 2-manifold with Polygon_mesh_processing. No step adds a point: every
// output vertex is one of the input points (duplicated where the surface
// pinches), so the sample density AWLOP produced is the mesh's.
#include "surface/meshing.h"

#include "core/vec3.h"
#include "surface/ordered_heap.h"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/manifoldness.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/Euler_operations.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <limits>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iterator>
#include <map>
#include <new>
#include <string>
#include <vector>

namespace vpr {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VertexIndex = SurfaceMesh::Vertex_index;
using FaceIndex = SurfaceMesh::Face_index;
using HalfedgeIndex = SurfaceMesh::Halfedge_index;
using Triangle = std::array<std::size_t, 3>;

// Input order is kept: CGAL point i is input point i, so soup indices are input indices.
Status to_cgal_points(const float* points, size_t n, std::vector<Point>* out) {
  if (n > size_t(UINT32_MAX)) return invalid_argument("meshing takes at most 2^32 - 1 points");
  out->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const float* p = points + 3 * i;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      return invalid_argument("meshing input point " + std::to_string(i) + " has a non-finite coordinate");
    (*out)[i] = Point(p[0], p[1], p[2]);
  }
  return Status::Ok();
}

// True when some four points span a volume (exact predicates). AFSR needs a
// 3D Delaunay triangulation; on a plane, a line or a point it has nothing to do.
bool spans_volume(const std::vector<Point>& p) {
  const size_t n = p.size();
  size_t b = 1;
  while (b < n && p[b] == p[0]) ++b;
  size_t c = b + 1;
  while (c < n && CGAL::collinear(p[0], p[b], p[c])) ++c;
  for (size_t d = c + 1; d < n; ++d)
    if (CGAL::orientation(p[0], p[b], p[c], p[d]) != CGAL::COPLANAR) return true;
  return false;
}

// Containers indexed by a Surface_mesh index (h.idx(), v.idx(), f.idx()) are
// sized by the index range, num_halfedges() and the like, which counts the
// elements removed since the last collect_garbage(); number_of_halfedges()
// does not, and a mesh that had faces removed has indices past it.
// Boundary cycles of the mesh: one border halfedge and the edge count of each.
std::vector<std::pair<HalfedgeIndex, size_t>> boundary_cycles(const SurfaceMesh& sm) {
  std::vector<std::pair<HalfedgeIndex, size_t>> cycles;
  std::vector<bool> seen(sm.num_halfedges(), false);
  for (HalfedgeIndex h : sm.halfedges()) {
    if (!sm.is_border(h) || seen[h.idx()]) continue;
    size_t length = 0;
    HalfedgeIndex g = h;
    do {
      seen[g.idx()] = true;
      ++length;
      g = sm.next(g);
    } while (g != h);
    cycles.emplace_back(h, length);
  }
  return cycles;
}

// Signed volume of a set of faces, measured from `origin`: positive when the
// faces wind counter-clockwise seen from outside (for a closed surface the
// origin does not matter; for one with small holes a central origin keeps the
// missing cones small).
double signed_volume(const SurfaceMesh& sm, const std::vector<FaceIndex>& faces, const Point& origin) {
  double volume = 0;
  for (FaceIndex f : faces) {
    HalfedgeIndex h = sm.halfedge(f);
    const Point& a = sm.point(sm.source(h));
    const Point& b = sm.point(sm.target(h));
    const Point& c = sm.point(sm.target(sm.next(h)));
    volume += CGAL::scalar_product(a - origin, CGAL::cross_product(b - origin, c - origin)) / 6.0;
  }
  return volume;
}

// Open or self-intersecting surfaces: per connected component, make the faces
// wind outward (positive signed volume about the component's centroid).
// Heuristic, but right for a closed shape with small unfilled holes, which is
// what AFSR leaves behind; nested shells all face outward.
void orient_open_components(SurfaceMesh& sm) {
  auto component = sm.add_property_map<FaceIndex, size_t>("f:vpr_component", 0).first;
  const size_t count = PMP::connected_components(sm, component);
  std::vector<std::vector<FaceIndex>> faces(count);
  std::vector<std::array<double, 4>> centroid(count, {0, 0, 0, 0});
  for (FaceIndex f : sm.faces()) {
    faces[component[f]].push_back(f);
    for (VertexIndex v : sm.vertices_around_face(sm.halfedge(f))) {
      const Point& p = sm.point(v);
      auto& c = centroid[component[f]];
      c[0] += p.x();
      c[1] += p.y();
      c[2] += p.z();
      c[3] += 1;
    }
  }
  for (size_t c = 0; c < count; ++c) {
    const auto& s = centroid[c];
    const Point origin(s[0] / s[3], s[1] / s[3], s[2] / s[3]);
    if (signed_volume(sm, faces[c], origin) < 0) PMP::reverse_face_orientations(faces[c], sm);
  }
  sm.remove_property_map(component);
}

// True when the soup is already what orient_polygon_soup makes of it: every
// directed edge used once (so no edge has more than two faces, and two
// faces on an edge run it in opposite directions) and the faces around each
// vertex one fan (its link one path or cycle). Then the call, which costs
// more than the rest of the repair on a dual mesh, would change nothing.
// border_from: if given, per vertex the end of its one outgoing edge that
// no face runs back (a border of the surface), or UINT32_MAX.
bool oriented_manifold_soup(const std::vector<Triangle>& soup, size_t n, std::vector<uint32_t>* border_from = nullptr) {
  if (border_from) border_from->assign(n, UINT32_MAX);
  // The link of v: an edge a -> b per face (v, a, b). Each a starts at most
  // one and each b ends at most one (the directed edges are unique: each
  // v -> a is a start in v's link, checked there), so the link is paths and
  // cycles; exactly one of them means one fan.
  std::vector<uint32_t> start(n + 1, 0);
  for (const Triangle& t : soup)
    for (int c = 0; c < 3; ++c) ++start[t[c] + 1];
  for (size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<std::array<uint32_t, 2>> link(start[n]);
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (const Triangle& t : soup)
      for (int c = 0; c < 3; ++c) link[fill[t[c]]++] = {uint32_t(t[(c + 1) % 3]), uint32_t(t[(c + 2) % 3])};
  }
  // Each vertex's link on its own, so the vertices in parallel (one answer
  // however they are shared out; border_from only matters when it is true).
  std::atomic<bool> one_fan{true};
  auto fan = [&](size_t v, std::vector<uint32_t>& ends) {
    auto* row = link.data() + start[v];
    const uint32_t count = start[v + 1] - start[v];
    if (count == 0) return true;
    std::sort(row, row + count);  // by start, for the walk's look-ups
    for (uint32_t k = 1; k < count; ++k)
      if (row[k][0] == row[k - 1][0]) return false;  // v -> a twice
    ends.clear();
    for (uint32_t k = 0; k < count; ++k) ends.push_back(row[k][1]);
    std::sort(ends.begin(), ends.end());
    // One path has one head (a start that is no end), one cycle none; more
    // heads are more pieces. Walk from the head (or any edge of a cycle): one
    // piece is met whole.
    uint32_t heads = 0, at = row[0][0];
    for (uint32_t k = 0; k < count; ++k)
      if (!std::binary_search(ends.begin(), ends.end(), row[k][0])) ++heads, at = row[k][0];
    if (heads > 1) return false;
    if (heads == 1 && border_from) (*border_from)[v] = at;
    const uint32_t begin = at;
    uint32_t walked = 0;
    while (walked < count) {
      const auto* next = std::lower_bound(row, row + count, std::array<uint32_t, 2>{at, 0});
      if (next == row + count || (*next)[0] != at) break;
      ++walked;
      at = (*next)[1];
      if (at == begin) break;
    }
    return walked == count;
  };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<uint32_t> ends;  // one vertex's link edges' ends, sorted (reused)
    for (size_t v = r.begin(); v != r.end() && one_fan.load(std::memory_order_relaxed); ++v)
      if (!fan(v, ends)) one_fan = false;
  });
  return one_fan;
}

// How a mesh of one connected component winds: by its signed volume about
// its corners' centroid, as orient_open_components measures it.
enum class Winding { kOutward, kInward, kUnknown };

// kOutward: one component winding outward (positive volume); neither
// orientation in repair_soup would change a face, and neither the
// self-intersection test nor the ray casts are needed. kInward: one
// component winding inward (an input whose faces wind inward gives a dual
// that does): both orientations would turn every face (a closed surface
// that does not cross itself has one volume from any origin, and
// orient_open_components measures this one), so the faces are turned
// without either. kUnknown: several components, or a volume of zero.
Winding one_component_winding(SurfaceMesh& sm) {
  auto component = sm.add_property_map<FaceIndex, size_t>("f:vpr_one", 0).first;
  const size_t count = PMP::connected_components(sm, component);
  sm.remove_property_map(component);
  if (count != 1) return Winding::kUnknown;
  std::vector<FaceIndex> faces(sm.faces().begin(), sm.faces().end());
  std::array<double, 4> c = {0, 0, 0, 0};
  for (FaceIndex f : faces)
    for (VertexIndex v : sm.vertices_around_face(sm.halfedge(f))) {
      const Point& p = sm.point(v);
      c[0] += p.x();
      c[1] += p.y();
      c[2] += p.z();
      c[3] += 1;
    }
  const double volume = signed_volume(sm, faces, Point(c[0] / c[3], c[1] / c[3], c[2] / c[3]));
  return volume > 0 ? Winding::kOutward : volume < 0 ? Winding::kInward : Winding::kUnknown;
}

double median_edge_length(const SurfaceMesh& sm) {
  std::vector<double> lengths;
  lengths.reserve(sm.number_of_edges());
  for (auto e : sm.edges())
    lengths.push_back(std::sqrt(CGAL::squared_distance(sm.point(sm.vertex(e, 0)), sm.point(sm.vertex(e, 1)))));
  if (lengths.empty()) return 0.0;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  return lengths[lengths.size() / 2];
}

double longest_edge(const SurfaceMesh& sm, const std::vector<FaceIndex>& faces) {
  double longest = 0.0;
  for (FaceIndex f : faces)
    for (auto h : sm.halfedges_around_face(sm.halfedge(f)))
      longest = std::max(longest, std::sqrt(CGAL::squared_distance(sm.point(sm.source(h)), sm.point(sm.target(h)))));
  return longest;
}

// Each triangle rotated to start at its smallest index (orientation kept),
// then the triangles sorted: one order for one set of faces.
void canonical_order(std::vector<Triangle>* triangles) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, triangles->size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      Triangle& t = (*triangles)[i];
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    }
  });
  // Equal triangles are equal values: one order on any thread count.
  tbb::parallel_sort(triangles->begin(), triangles->end());
}

// The repair of a soup that needs none: an oriented 2-manifold
// (oriented_manifold_soup) with no face over the bridge bound, no hole to
// fill and one edge-connected part whose volume has a clear sign, which is
// what a CVT's dual (cluster_mesh.h) nearly always is. repair_soup would
// build a CGAL mesh only to turn no face, split no vertex and fill nothing;
// this gives its result (the same vertices in the same order, the same faces,
// sources and stats) from the soup directly (igea at 50,000 on 2 cores: the
// check and this 26-28 ms, the check and CGAL's way 92 ms). No global sort:
// the borders come from the check (border_from), the parts from the faces'
// vertices (where every vertex is one fan, faces joined through vertices are
// joined through edges). False, with nothing written, where any of that does
// not hold: repair_soup then runs as before.
bool repair_clean_soup(const float* points, size_t n, const std::vector<Triangle>& soup,
                       const std::vector<uint32_t>& border_from, const MeshingOptions& options, Mesh* out,
                       std::vector<uint32_t>* source_point, MeshingStats* stats) {
  if (soup.empty() || n == 0) return false;
  const size_t nf = soup.size();
  auto point = [&](size_t v) { return Vec3d{points[3 * v], points[3 * v + 1], points[3 * v + 2]}; };
  // Bridges: an edge over max_edge_ratio x the median edge would remove
  // faces. Each edge once, as CGAL lists a mesh's edges: a face's edge u -> w
  // where u < w, or where it is a border (no face runs w -> u).
  std::vector<double> lengths;
  lengths.reserve(3 * nf / 2 + 1);
  for (const Triangle& t : soup)
    for (int c = 0; c < 3; ++c) {
      const uint32_t u = uint32_t(t[c]), w = uint32_t(t[(c + 1) % 3]);
      if (u < w || border_from[u] == w) lengths.push_back(std::sqrt(norm2(point(u) - point(w))));
    }
  if (lengths.empty()) return false;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  const double max_edge = options.max_edge_ratio * lengths[lengths.size() / 2];
  for (double length : lengths)
    if (length > max_edge) return false;
  // Holes: each border is a cycle (CGAL's border halfedges run against the
  // faces' edges); with max_hole_edges > 0 some would be filled.
  size_t cycles = 0;
  {
    std::vector<uint32_t> next(n, UINT32_MAX);
    for (uint32_t u = 0; u < n; ++u)
      if (border_from[u] != UINT32_MAX) next[border_from[u]] = u;
    std::vector<char> seen(n, 0);
    for (uint32_t v = 0; v < n; ++v) {
      if (next[v] == UINT32_MAX || seen[v]) continue;
      ++cycles;
      for (uint32_t w = v; !seen[w]; w = next[w]) seen[w] = 1;
    }
  }
  if (cycles > 0 && options.max_hole_edges > 0) return false;
  // The points no face uses (collect_garbage removes them, below).
  std::vector<char> removed(n, 1);
  for (const Triangle& t : soup)
    for (size_t v : t) removed[v] = 0;
  // One part whose faces join across edges, as connected_components counts
  // them: where every vertex is one fan, the same as joined through vertices.
  {
    std::vector<uint32_t> parent(n);
    for (uint32_t v = 0; v < n; ++v) parent[v] = v;
    auto root = [&](uint32_t v) {
      while (parent[v] != v) v = parent[v] = parent[parent[v]];
      return v;
    };
    size_t parts = size_t(std::count(removed.begin(), removed.end(), 0));
    for (const Triangle& t : soup)
      for (int c = 1; c < 3; ++c) {
        const uint32_t x = root(uint32_t(t[0])), y = root(uint32_t(t[c]));
        if (x != y) parent[std::max(x, y)] = std::min(x, y), --parts;
      }
    if (parts != 1) return false;
  }
  // Its winding, by the signed volume about its corners' centroid
  // (one_component_winding); a volume near zero is left to repair_soup.
  Vec3d centroid{0, 0, 0};
  for (const Triangle& t : soup)
    for (int c = 0; c < 3; ++c) centroid = centroid + point(t[c]);
  centroid = centroid * (1.0 / double(3 * nf));
  double volume = 0, magnitude = 0;
  for (const Triangle& t : soup) {
    const double v = dot(point(t[0]) - centroid, cross(point(t[1]) - centroid, point(t[2]) - centroid)) / 6.0;
    volume += v, magnitude += std::abs(v);
  }
  if (!(std::abs(volume) > 1e-9 * magnitude)) return false;
  // Unused points go as collect_garbage removes vertices: the last kept one
  // moves into the first gap, and so on (Surface_mesh::collect_garbage).
  std::vector<uint32_t> at(n);  // at[i]: the point in slot i
  for (uint32_t v = 0; v < n; ++v) at[v] = v;
  size_t i0 = 0, i1 = n - 1;
  while (true) {
    while (!removed[i0] && i0 < i1) ++i0;
    while (removed[i1] && i0 < i1) --i1;
    if (i0 >= i1) break;
    std::swap(removed[i0], removed[i1]);
    std::swap(at[i0], at[i1]);
  }
  const size_t kept = removed[i0] ? i0 : i0 + 1;
  std::vector<uint32_t> slot(n, UINT32_MAX);
  for (size_t i = 0; i < kept; ++i) slot[at[i]] = uint32_t(i);
  Mesh mesh;
  mesh.positions.reserve(3 * kept);
  for (size_t i = 0; i < kept; ++i)
    mesh.positions.insert(mesh.positions.end(), points + 3 * at[i], points + 3 * at[i] + 3);
  std::vector<Triangle> faces(nf);
  for (size_t f = 0; f < nf; ++f) {
    faces[f] = {slot[soup[f][0]], slot[soup[f][1]], slot[soup[f][2]]};
    if (volume < 0) std::swap(faces[f][1], faces[f][2]);  // reverse_face_orientations
  }
  canonical_order(&faces);
  mesh.indices.reserve(3 * nf);
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) mesh.indices.push_back(uint32_t(t[c]));
  if (!(total_area(mesh) > 0.0)) return false;  // repair_soup says why
  if (stats) {
    *stats = MeshingStats{};
    stats->points_in = n;
    stats->vertices_out = kept;
    stats->points_dropped = n - kept;
    stats->holes_left = cycles;
  }
  *out = std::move(mesh);
  if (source_point) *source_point = std::vector<uint32_t>(at.begin(), at.begin() + kept);
  return true;
}

// soup_points: the n input points in input order (as CGAL points); soup: triangles over them.
Status repair_soup(const float* points, size_t n, std::vector<Point> soup_points, std::vector<Triangle> soup,
                   const MeshingOptions& options, Mesh* out, std::vector<uint32_t>* source_point, MeshingStats* stats) {
  std::vector<uint32_t> border_from;
  const bool oriented = oriented_manifold_soup(soup, soup_points.size(), &border_from);
  if (oriented && options.clean_soup_shortcut &&
      repair_clean_soup(points, n, soup, border_from, options, out, source_point, stats))
    return Status::Ok();
  // Consistent orientation; points are duplicated (appended after the n inputs)
  // wherever the facets meet along a non-manifold edge or vertex.
  if (!oriented) PMP::orient_polygon_soup(soup_points, soup);
  size_t split = soup_points.size() - n;

  SurfaceMesh sm;
  PMP::polygon_soup_to_polygon_mesh(soup_points, soup, sm);  // vertex i = soup point i
  // Which input point each vertex is. Vertices made by duplication (soup points
  // past n, and those added below) get theirs by exact position lookup at the end.
  auto source = sm.add_property_map<VertexIndex, uint32_t>("v:vpr_source", UINT32_MAX).first;
  for (VertexIndex v : sm.vertices())
    if (v.idx() < n) source[v] = uint32_t(v.idx());
  split += PMP::duplicate_non_manifold_vertices(sm);  // triangulate_hole needs manifold borders

  // Close small holes with the hole's own vertices (no refinement: the
  // vertices are the AWLOP particles and stay exactly those).
  // A face with an edge much longer than the median bridges separate parts:
  // AFSR fans a lone particle on a thin tip to the body it faces. Such faces
  // are removed here, so that the hole they leave is closed below from its
  // own short edges. A hole patch with such an edge is likewise taken out again
  // and the hole stays open.
  const double max_edge = options.max_edge_ratio * median_edge_length(sm);
  std::vector<FaceIndex> bridges;
  for (FaceIndex f : sm.faces())
    if (longest_edge(sm, {f}) > max_edge) bridges.push_back(f);
  for (FaceIndex f : bridges) CGAL::Euler::remove_face(sm.halfedge(f), sm);
  if (!bridges.empty()) split += PMP::duplicate_non_manifold_vertices(sm);
  size_t filled = 0, left = 0;
  for (const auto& [border, length] : boundary_cycles(sm)) {
    if (!sm.is_border(border)) continue;  // each patch closes only its own cycle; be sure
    if (length > options.max_hole_edges) {
      ++left;
      continue;
    }
    std::vector<FaceIndex> patch;
    PMP::triangulate_hole(sm, border, std::back_inserter(patch));
    if (patch.empty()) {
      ++left;
      continue;
    }
    if (longest_edge(sm, patch) > max_edge) {
      for (FaceIndex f : patch) CGAL::Euler::remove_face(sm.halfedge(f), sm);
      ++left;
      continue;
    }
    ++filled;
  }
  split += PMP::duplicate_non_manifold_vertices(sm);

  // Drop the points the reconstruction left out (repeated points, outliers):
  // orient_to_bound_a_volume also requires a mesh without isolated vertices.
  for (VertexIndex v : sm.vertices())
    if (sm.is_isolated(v)) sm.remove_vertex(v);
  sm.collect_garbage();  // compact indices; property maps follow

  // orient_to_bound_a_volume needs a closed mesh that does not intersect
  // itself (its documented precondition): on one that does, its ray casts
  // can retry forever (the pipeline fuzzer found a 101-triangle soup that
  // held it for minutes). Such meshes, and open ones, get each component
  // outward by its own signed volume instead.
  const Winding winding = one_component_winding(sm);
  if (winding == Winding::kOutward) {
    // already outward: nothing to turn
  } else if (winding == Winding::kInward) {
    PMP::reverse_face_orientations(sm);
  } else if (CGAL::is_closed(sm) && !PMP::does_self_intersect(sm)) {
    PMP::orient_to_bound_a_volume(sm);  // outward; inner shells of nested components inward
  } else {
    orient_open_components(sm);
  }

  std::map<std::array<float, 3>, uint32_t> input_index;  // built only if duplicates need it
  for (VertexIndex v : sm.vertices()) {
    if (source[v] != UINT32_MAX) continue;
    if (input_index.empty())
      for (size_t i = n; i-- > 0;)  // reverse: the lowest index wins for repeated points
        input_index[{points[3 * i], points[3 * i + 1], points[3 * i + 2]}] = uint32_t(i);
    const Point& p = sm.point(v);  // a copy of an input float triple: exact
    source[v] = input_index.at({float(p.x()), float(p.y()), float(p.z())});
  }

  // Flatten: after collect_garbage vertex v has index v.idx() < num_vertices().
  Mesh mesh;
  std::vector<uint32_t> sources(sm.num_vertices());
  std::vector<bool> used(n, false);
  mesh.positions.reserve(3 * sm.number_of_vertices());
  for (VertexIndex v : sm.vertices()) {
    const uint32_t s = source[v];
    sources[v.idx()] = s;
    used[s] = true;
    mesh.positions.insert(mesh.positions.end(), points + 3 * s, points + 3 * s + 3);
  }
  std::vector<Triangle> faces;
  faces.reserve(sm.number_of_faces());
  for (FaceIndex f : sm.faces()) {
    Triangle t;
    int c = 0;
    for (VertexIndex v : sm.vertices_around_face(sm.halfedge(f))) t[c++] = v.idx();
    faces.push_back(t);
  }
  canonical_order(&faces);
  mesh.indices.reserve(3 * faces.size());
  for (const Triangle& t : faces)
    for (int c = 0; c < 3; ++c) mesh.indices.push_back(uint32_t(t[c]));

  // Facets through points on one line (or repeated points) survive the repair
  // as faces of zero area; such a result is no surface, and saying so here
  // keeps the promise that what these functions return passes validate_mesh.
  if (mesh.indices.empty() || !(total_area(mesh) > 0.0))
    return invalid_argument("meshing: no face of the " + std::to_string(n) +
                            " points has a positive area (they lie on a line or repeat)");

  if (stats) {
    *stats = MeshingStats{};
    stats->points_in = n;
    stats->vertices_out = sources.size();
    stats->points_dropped = size_t(std::count(used.begin(), used.end(), false));
    stats->holes_filled = filled;
    stats->holes_left = left;
    stats->vertices_split = split;
    stats->bridges_removed = bridges.size();
  }
  *out = std::move(mesh);
  if (source_point) *source_point = std::move(sources);
  return Status::Ok();
}

// AFSR inside an OrderedHeapScope (see ordered_heap.h: its ties are broken
// by heap addresses). Everything AFSR allocates dies inside the scope; the
// facets leave through a malloc'ed buffer, errors through a stack buffer.
Status reconstruct_in_allocation_order(const std::vector<Point>& points, const MeshingOptions& options,
                                       std::vector<Triangle>* soup) {
  // Measured: AFSR of 10k-20k points takes well under 1 KiB per point; 8 KiB
  // per point leaves room (the reservation costs address space only).
  const size_t bytes = (size_t(256) << 20) + points.size() * 8192;
  Triangle* facets = nullptr;
  size_t count = 0;
  char error[512] = {0};
  bool out_of_memory = false;
  {
    OrderedHeapScope ordered(bytes);
    try {
      std::vector<Triangle> inside;
      CGAL::advancing_front_surface_reconstruction(points.begin(), points.end(), std::back_inserter(inside),
                                                   options.radius_ratio_bound, options.beta);
      count = inside.size();
      facets = static_cast<Triangle*>(std::malloc(std::max<size_t>(1, count) * sizeof(Triangle)));
      if (facets) std::copy(inside.begin(), inside.end(), facets);
      else out_of_memory = true;
    } catch (const std::bad_alloc&) {
      out_of_memory = true;
    } catch (const std::exception& e) {
      std::snprintf(error, sizeof error, "%s", e.what());
      if (!error[0]) std::snprintf(error, sizeof error, "unknown error");
    }
  }
  if (out_of_memory) return resource_exhausted("meshing ran out of memory on " + std::to_string(points.size()) + " points");
  if (error[0]) return internal_error(std::string("meshing failed inside CGAL: ") + error);
  soup->assign(facets, facets + count);
  std::free(facets);
  return Status::Ok();
}

// The parallel path of MeshingOptions (slabs with halos, facets kept by
// centroid, accepted only when every seam closes). Returns false, with the
// number of seam defects, when the slabs do not agree and the caller must
// reconstruct the points whole.
StatusOr<bool> reconstruct_in_slabs(const std::vector<Point>& points, const MeshingOptions& options,
                                    std::vector<Triangle>* soup, size_t* slab_count, size_t* seam_defects) {
  const size_t n = points.size();
  const size_t slabs = std::min(options.max_slabs, options.points_per_slab ? n / options.points_per_slab : 0);
  *slab_count = 1;
  if (slabs < 2 || !(options.spacing > 0) || !std::isfinite(options.spacing)) return false;

  // Cut along the longest axis of the bounding box, at quantiles of the points.
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = points[0][a];
  for (const Point& p : points)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
  std::vector<double> sorted(n);
  for (size_t i = 0; i < n; ++i) sorted[i] = points[i][axis];
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> cut(slabs + 1);
  cut[0] = -std::numeric_limits<double>::infinity();
  cut[slabs] = std::numeric_limits<double>::infinity();
  for (size_t s = 1; s < slabs; ++s) cut[s] = sorted[s * n / slabs];
  const double halo = options.halo_spacings * options.spacing;

  std::vector<std::vector<Triangle>> kept(slabs);
  std::vector<Status> status(slabs);
  tbb::parallel_for(size_t(0), slabs, [&](size_t s) {
    std::vector<Point> local;
    std::vector<size_t> global;
    for (size_t i = 0; i < n; ++i) {
      const double x = points[i][axis];
      if (x >= cut[s] - halo && x < cut[s + 1] + halo) {
        local.push_back(points[i]);
        global.push_back(i);
      }
    }
    std::vector<Triangle> facets;
    if (local.size() >= 4) status[s] = reconstruct_in_allocation_order(local, options, &facets);
    for (Triangle t : facets) {
      for (size_t& v : t) v = global[v];
      const double centroid = (points[t[0]][axis] + points[t[1]][axis] + points[t[2]][axis]) / 3.0;
      if (centroid >= cut[s] && centroid < cut[s + 1]) kept[s].push_back(t);
    }
  });
  for (const Status& st : status) VPR_RETURN_IF_ERROR(st);

  soup->clear();
  for (const auto& k : kept) soup->insert(soup->end(), k.begin(), k.end());
  // Seams: every edge with both ends near a cut must be shared by exactly two
  // facets, as it is in the interior of a closed reconstruction.
  auto near_cut = [&](size_t v) {
    const double x = points[v][axis];
    for (size_t s = 1; s < slabs; ++s)
      if (std::abs(x - cut[s]) < halo) return true;
    return false;
  };
  std::vector<std::pair<size_t, size_t>> edges;
  for (const Triangle& t : *soup)
    for (int c = 0; c < 3; ++c) {
      const size_t a = t[c], b = t[(c + 1) % 3];
      if (near_cut(a) && near_cut(b)) edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  size_t defects = 0;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    defects += (j - i) != 2;
    i = j;
  }
  *seam_defects = defects;
  if (defects > 0) return false;
  *slab_count = slabs;
  return true;
}

Status mesh_points_impl(const float* points, size_t n, const MeshingOptions& options, Mesh* out,
                        std::vector<uint32_t>* source_point, MeshingStats* stats) {
  if (n < 4) return invalid_argument("meshing needs at least 4 points, got " + std::to_string(n));
  if (!(options.radius_ratio_bound > 0) || !std::isfinite(options.radius_ratio_bound))
    return invalid_argument("meshing radius_ratio_bound must be positive, got " +
                            std::to_string(options.radius_ratio_bound));
  if (!(options.beta > 0) || !std::isfinite(options.beta))
    return invalid_argument("meshing beta must be positive, got " + std::to_string(options.beta));

  std::vector<Point> soup_points;
  VPR_RETURN_IF_ERROR(to_cgal_points(points, n, &soup_points));
  if (!spans_volume(soup_points))
    return invalid_argument("meshing needs points that span a volume; all " + std::to_string(n) +
                            " points are coplanar");

  std::vector<Triangle> soup;
  size_t slabs = 1, seam_defects = 0;
  VPR_ASSIGN_OR_RETURN(const bool in_slabs,
                       reconstruct_in_slabs(soup_points, options, &soup, &slabs, &seam_defects));
  if (!in_slabs) VPR_RETURN_IF_ERROR(reconstruct_in_allocation_order(soup_points, options, &soup));
  if (soup.empty())
    return invalid_argument("meshing: the reconstruction found no surface through the " + std::to_string(n) +
                            " points");
  // AFSR emits the same facets in an order that depends on memory addresses;
  // sort them so the repair below, and the result, are reproducible.
  canonical_order(&soup);

  VPR_RETURN_IF_ERROR(
      repair_soup(points, n, std::move(soup_points), std::move(soup), options, out, source_point, stats));
  if (stats) {
    stats->slabs = slabs;
    stats->seam_defects = seam_defects;
  }
  return Status::Ok();
}

// CGAL may throw (failed assertions in debug builds, failed constructions);
// bad input must not end the process.
template <class Fn>
Status guarded(size_t n, Fn fn) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
    return resource_exhausted("meshing ran out of memory on " + std::to_string(n) + " points");
  } catch (const std::exception& e) {
    return internal_error(std::string("meshing failed inside CGAL: ") + e.what());
  }
}

}  // namespace

Status mesh_points(const float* points, size_t n, const MeshingOptions& options, Mesh* out,
                   std::vector<uint32_t>* source_point, MeshingStats* stats) {
  return guarded(n, [&] { return mesh_points_impl(points, n, options, out, source_point, stats); });
}

Status repair_triangle_soup(const float* points, size_t n, const uint32_t* triangles, size_t triangle_count,
                            const MeshingOptions& options, Mesh* out, std::vector<uint32_t>* source_point,
                            MeshingStats* stats) {
  if (triangle_count == 0) return invalid_argument("soup repair needs at least one triangle, got 0");
  std::vector<Triangle> soup(triangle_count);
  for (size_t t = 0; t < triangle_count; ++t) {
    const uint32_t* v = triangles + 3 * t;
    for (int c = 0; c < 3; ++c)
      if (v[c] >= n)
        return invalid_argument("soup triangle " + std::to_string(t) + " references point " + std::to_string(v[c]) +
                                " but there are " + std::to_string(n) + " points");
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0])
      return invalid_argument("soup triangle " + std::to_string(t) + " repeats a vertex");
    soup[t] = {v[0], v[1], v[2]};
  }
  return guarded(n, [&]() -> Status {
    std::vector<Point> soup_points;
    VPR_RETURN_IF_ERROR(to_cgal_points(points, n, &soup_points));
    return repair_soup(points, n, std::move(soup_points), std::move(soup), options, out, source_point, stats);
  });
}

}  // namespace vpr
