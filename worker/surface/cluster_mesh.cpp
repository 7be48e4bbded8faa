#include "surface/cluster_mesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>

#include "core/bucket_sort.h"
#include "core/collect_in_order.h"
#include "core/mesh_parts.h"
#include "core/step_marks.h"
#include "core/vec3.h"
#include "core/vertex_ranges.h"
#include "surface/dual_projection.h"
#include "surface/edge_flips.h"

namespace vpr {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d eig(const Vec3d& v) {
  return {v.x, v.y, v.z};
}

// The faces of the surface that touch a cell (in face order), with their
// bounding spheres (made only where the host projects).
struct CellFaces {
  std::vector<uint32_t> face;
  std::vector<std::array<float, 4>> sphere;
  FaceList list() const { return {face.data(), sphere.data(), uint32_t(face.size())}; }
};

struct Quadric {
  Matrix3d a = Matrix3d::Zero();
  Vector3d b = Vector3d::Zero();  // sum w n d
  void add_plane(const Vector3d& n, const Vector3d& point, double w) {
    a += w * n * n.transpose();
    b += w * n * n.dot(point);
  }
};

// Face f's unit normal and area (the normal only where the area is positive).
void face_plane(const Mesh& surface, size_t f, Vector3d* n, double* area) {
  const uint32_t* t = &surface.indices[3 * f];
  const Vector3d a = eig(load3d(surface.positions.data(), t[0])), b = eig(load3d(surface.positions.data(), t[1])),
                 c = eig(load3d(surface.positions.data(), t[2]));
  const Vector3d cr = (b - a).cross(c - a);
  *area = 0.5 * cr.norm();
  if (*area > 0) *n = cr.normalized();
}

// Every face's plane, in parallel (zero normals where the area is zero).
void face_planes(const Mesh& surface, std::vector<Vec3d>* normal, std::vector<double>* area) {
  const size_t nf = surface.face_count();
  normal->resize(nf);
  area->resize(nf);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f) {
      Vector3d n = Vector3d::Zero();
      face_plane(surface, f, &n, &(*area)[f]);
      (*normal)[f] = Vec3d{n.x(), n.y(), n.z()};
    }
  });
}

uint64_t key2(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
}

// Holes of a triangle set: directed edges without their opposite. A loop
// whose vertices all lie on the input's boundary is the input's boundary:
// kept (counted in *kept). Other simple loops (each vertex with one outgoing
// boundary edge) are closed by a fan, in the orientation that continues the
// surface, from a corner none of whose diagonals is an edge already (one that
// is would get a third face); a loop with no such corner stays open. Returns
// how many were closed.
template <class OnBoundary>
size_t close_dual_holes(std::vector<std::array<uint32_t, 3>>* tris, OnBoundary on_boundary, size_t* kept) {
  // Directed edges as sorted keys (u << 32 | v); the fans' edges go to a
  // second sorted list, so that later fans see them.
  auto key = [](uint32_t u, uint32_t v) { return uint64_t(u) << 32 | v; };
  // Made, sorted and searched in parallel (plain keys: one order on any
  // thread count).
  std::vector<uint64_t> directed(3 * tris->size()), added;
  uint32_t top = 0;
  for (const auto& t : *tris) top = std::max({top, t[0], t[1], t[2]});
  tbb::parallel_for(tbb::blocked_range<size_t>(0, tris->size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t f = r.begin(); f != r.end(); ++f)
      for (int c = 0; c < 3; ++c) directed[3 * f + c] = key((*tris)[f][c], (*tris)[f][(c + 1) % 3]);
  });
  tbb::parallel_sort(directed.begin(), directed.end());
  directed.erase(std::unique(directed.begin(), directed.end()), directed.end());
  auto has = [&](uint32_t u, uint32_t v) {
    return std::binary_search(directed.begin(), directed.end(), key(u, v)) ||
           std::binary_search(added.begin(), added.end(), key(u, v));
  };
  // Boundary edges (no opposite), in (u, v) order: next[u] is a run of them.
  const std::vector<uint64_t> open = collect_in_order<uint64_t>(
      directed.size(), [&](size_t i, std::vector<uint64_t>* out) {
        const uint64_t e = directed[i];
        if (!std::binary_search(directed.begin(), directed.end(), key(uint32_t(e), uint32_t(e >> 32)))) out->push_back(e);
      }, 4096);
  auto outs = [&](uint32_t u) {
    const auto lo = std::lower_bound(open.begin(), open.end(), key(u, 0));
    const auto hi = std::lower_bound(lo, open.end(), key(u + 1, 0));
    return std::make_pair(lo, hi);
  };
  std::vector<char> done(size_t(top) + 1, 0);
  size_t closed = 0;
  *kept = 0;
  for (size_t i = 0; i < open.size(); ++i) {
    const uint32_t start = uint32_t(open[i] >> 32);
    if (i > 0 && uint32_t(open[i - 1] >> 32) == start) continue;  // one turn per vertex
    if (done[start]) continue;
    std::vector<uint32_t> loop;
    bool simple = false, all_boundary = true;
    uint32_t v = start;
    while (true) {
      const auto [lo, hi] = outs(v);
      if (hi - lo != 1 || done[v]) break;
      done[v] = 1;
      loop.push_back(v);
      all_boundary = all_boundary && on_boundary(v);
      v = uint32_t(*lo);
      if (v == start) {
        simple = true;
        break;
      }
    }
    if (!simple || loop.size() < 3) continue;
    if (all_boundary) {
      ++*kept;
      continue;
    }
    const size_t n = loop.size();
    auto is_edge = [&](uint32_t a, uint32_t b) { return has(a, b) || has(b, a); };
    size_t apex = 0;
    for (; apex < n; ++apex) {
      bool clear = true;
      for (size_t j = 2; j + 1 < n && clear; ++j) clear = !is_edge(loop[apex], loop[(apex + j) % n]);
      if (clear) break;
    }
    if (apex == n) continue;
    std::rotate(loop.begin(), loop.begin() + apex, loop.end());
    // The loop runs along the triangles' edges; the patch runs against it.
    for (size_t i = 1; i + 1 < n; ++i) {
      tris->push_back({loop[0], loop[i + 1], loop[i]});
      for (uint64_t e : {key(loop[0], loop[i + 1]), key(loop[i + 1], loop[i]), key(loop[i], loop[0])})
        added.insert(std::upper_bound(added.begin(), added.end(), e), e);
    }
    ++closed;
  }
  return closed;
}

// Keeps the faces `keep` says yes to, and the vertices they use (with their
// source cells).
template <class Keep>
void keep_faces(Mesh* mesh, std::vector<uint32_t>* source, Keep keep) {
  const size_t nv = mesh->vertex_count(), nf = mesh->face_count();
  std::vector<uint32_t> kept;
  for (size_t f = 0; f < nf; ++f)
    if (keep(f)) kept.insert(kept.end(), &mesh->indices[3 * f], &mesh->indices[3 * f] + 3);
  if (kept.size() == mesh->indices.size()) return;
  std::vector<uint32_t> remap(nv, UINT32_MAX);
  Mesh out;
  std::vector<uint32_t> out_source;
  for (uint32_t& v : kept) {
    if (remap[v] == UINT32_MAX) {
      remap[v] = uint32_t(out.vertex_count());
      out.positions.insert(out.positions.end(), mesh->positions.begin() + 3 * v, mesh->positions.begin() + 3 * v + 3);
      out_source.push_back((*source)[v]);
    }
    v = remap[v];
  }
  out.indices = std::move(kept);
  *mesh = std::move(out);
  *source = std::move(out_source);
}

// Pieces of fewer than four faces are what the manifold repair cuts off a
// non-manifold edge (a fin, or two triangles back to back), never a part of
// the surface: a closed part needs four faces, and every part of the input
// gets at least four cells. Dropped, with the vertices no face uses any more.
void drop_slivers(Mesh* mesh, std::vector<uint32_t>* source) {
  size_t pieces = 0;
  const std::vector<uint32_t> piece = face_parts(*mesh, &pieces);
  std::vector<uint32_t> faces(pieces, 0);
  for (uint32_t p : piece) ++faces[p];
  keep_faces(mesh, source, [&](size_t f) { return faces[piece[f]] >= 4; });
}

// The scraps of drop_extra_pieces: surface_part (per face of `surface`) and
// parts from face_parts(surface).
void drop_scraps(Mesh* mesh, std::vector<uint32_t>* source, const Mesh& surface,
                 const std::vector<uint32_t>& surface_part, const std::vector<uint32_t>& label, size_t parts) {
  size_t pieces = 0;
  const std::vector<uint32_t> piece = face_parts(*mesh, &pieces);
  if (pieces <= parts) return;
  uint32_t cells = 0;
  for (uint32_t c : *source) cells = std::max(cells, c + 1);
  std::vector<uint32_t> part_of_cell(cells, UINT32_MAX);  // the input part a cell lies on
  for (size_t f = 0; f < surface.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t cell = label[surface.indices[3 * f + k]];
      if (cell < cells && surface_part[f] != UINT32_MAX) part_of_cell[cell] = surface_part[f];
    }
  std::vector<double> area(pieces, 0.0);
  std::vector<uint32_t> part_of_piece(pieces, UINT32_MAX);
  for (size_t f = 0; f < mesh->face_count(); ++f) {
    const uint32_t* t = &mesh->indices[3 * f];
    const Vector3d a = eig(load3d(mesh->positions.data(), t[0])), b = eig(load3d(mesh->positions.data(), t[1])),
                   c = eig(load3d(mesh->positions.data(), t[2]));
    area[piece[f]] += 0.5 * (b - a).cross(c - a).norm();
    if (part_of_piece[piece[f]] == UINT32_MAX) part_of_piece[piece[f]] = part_of_cell[(*source)[t[0]]];
  }
  std::vector<uint32_t> largest(parts, UINT32_MAX);  // per input part, its largest piece
  for (uint32_t p = 0; p < pieces; ++p) {
    const uint32_t q = part_of_piece[p];
    if (q != UINT32_MAX && (largest[q] == UINT32_MAX || area[p] > area[largest[q]])) largest[q] = p;
  }
  std::vector<char> drop(pieces, 0);
  bool any = false;
  for (uint32_t p = 0; p < pieces; ++p) {
    const uint32_t q = part_of_piece[p];
    if (q != UINT32_MAX && largest[q] != p && area[p] < 0.01 * area[largest[q]]) drop[p] = 1, any = true;
  }
  if (any) keep_faces(mesh, source, [&](size_t f) { return !drop[piece[f]]; });
}

// Pieces of the output beyond the input's parts, dropped, only while the
// output has more pieces than the input (`surface`, whose vertices' cells
// are `label`) has parts:
// - Flat pillows: closed pieces that enclose no volume (two sheets on the
//   same coplanar vertices) are what the dual makes where a triple of cells
//   wraps a sharp fold (suzanne.obj at ten times its vertex count gave an
//   18-vertex one on its keel, a fourth part where the input has three).
//   Smallest first, so that a card the input models as a flat closed part
//   keeps its dual.
// - Scraps: where one input part comes out in several pieces, those under 1%
//   of the area of its largest piece (suzanne.obj at 5,000 gave a closed
//   4-face scrap, 0.2% of the model's diagonal across, beside its eye, where
//   the dual wraps a thin fold). A larger second piece stays: it is surface
//   a person would miss.
void drop_extra_pieces(Mesh* mesh, std::vector<uint32_t>* source, const Mesh& surface,
                       const std::vector<uint32_t>& label) {
  size_t pieces = 0;
  const std::vector<uint32_t> piece = face_parts(*mesh, &pieces);
  if (pieces <= 1) return;  // the input has a part at least: skip counting its parts
  size_t input_parts = 0;
  const std::vector<uint32_t> surface_part = face_parts(surface, &input_parts);
  if (pieces <= input_parts) return;
  std::vector<double> area(pieces, 0.0), volume(pieces, 0.0);
  std::vector<uint32_t> faces(pieces, 0);
  std::unordered_map<uint64_t, int> uses;  // edge -> faces using it (pieces share no vertex)
  for (size_t f = 0; f < mesh->face_count(); ++f) {
    const uint32_t* t = &mesh->indices[3 * f];
    const Vector3d a = eig(load3d(mesh->positions.data(), t[0])), b = eig(load3d(mesh->positions.data(), t[1])),
                   c = eig(load3d(mesh->positions.data(), t[2]));
    area[piece[f]] += 0.5 * (b - a).cross(c - a).norm();
    volume[piece[f]] += a.dot(b.cross(c)) / 6;
    ++faces[piece[f]];
    for (int k = 0; k < 3; ++k) ++uses[key2(t[k], t[(k + 1) % 3])];
  }
  std::vector<char> open(pieces, 0);
  for (size_t f = 0; f < mesh->face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      if (uses[key2(mesh->indices[3 * f + k], mesh->indices[3 * f + (k + 1) % 3])] != 2) open[piece[f]] = 1;
  std::vector<uint32_t> flat;
  for (uint32_t p = 0; p < pieces; ++p)  // a sphere encloses 0.094 A^1.5; a plate 1% thick 0.0035 A^1.5
    if (!open[p] && std::abs(volume[p]) <= 1e-6 * std::pow(area[p], 1.5)) flat.push_back(p);
  std::stable_sort(flat.begin(), flat.end(), [&](uint32_t x, uint32_t y) { return faces[x] < faces[y]; });
  flat.resize(std::min(flat.size(), pieces - input_parts));
  if (!flat.empty()) {
    std::vector<char> drop(pieces, 0);
    for (uint32_t p : flat) drop[p] = 1;
    keep_faces(mesh, source, [&](size_t f) { return !drop[piece[f]]; });
  }
  drop_scraps(mesh, source, surface, surface_part, label, input_parts);
}

// Whether the points of two cells with weight lie within `near` of each
// other (x, y, z per cell). Most duals have no such pair; then no cell of the
// in-order pass below clashes, and it is skipped. The points sorted by x in
// parallel, each one compared with those after it less than `near` further
// in x (x differences of floats are exact in double, so no closer pair is
// missed).
bool any_within(const std::vector<float>& points, const std::vector<double>& weight, double near) {
  auto point = [&](uint32_t cell) {
    return Vector3d(points[3 * size_t(cell)], points[3 * size_t(cell) + 1], points[3 * size_t(cell) + 2]);
  };
  std::vector<std::pair<double, uint32_t>> by_x = collect_in_order<std::pair<double, uint32_t>>(
      weight.size(), [&](size_t c, std::vector<std::pair<double, uint32_t>>* out) {
        if (weight[c] > 0) out->push_back({double(points[3 * c]), uint32_t(c)});
      });
  tbb::parallel_sort(by_x.begin(), by_x.end());
  std::atomic<bool> found{false};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, by_x.size(), 2048), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end() && !found.load(std::memory_order_relaxed); ++i)
      for (size_t j = i + 1; j < by_x.size() && by_x[j].first - by_x[i].first < near; ++j)
        if ((point(by_x[j].second) - point(by_x[i].second)).squaredNorm() < near * near) found = true;
  });
  return found;
}

// One round of tangential relaxation (relax_move in dual_projection.h):
// every vertex moves at once (one order on any thread count), on the device
// when there is one; then, on the host, a move that turns one of its
// triangles by more than a right angle is undone.
Status relax_tangentially(Mesh* mesh, const std::vector<uint32_t>& source, const std::vector<Freedom>& freedom,
                          const std::vector<Vec3d>& line, const Mesh& surface, const std::vector<CellFaces>& cell_faces,
                          DualProjector* device) {
  const size_t nv = mesh->vertex_count(), nf = mesh->face_count();
  auto p = [&](uint32_t v) { return load3d(mesh->positions.data(), v); };
  std::vector<uint32_t> face_start(nv + 1, 0), faces_of(3 * nf);
  for (uint32_t v : mesh->indices) ++face_start[v + 1];
  for (size_t v = 0; v < nv; ++v) face_start[v + 1] += face_start[v];
  {
    std::vector<uint32_t> fill(face_start.begin(), face_start.end() - 1);
    for (size_t f = 0; f < nf; ++f)
      for (int c = 0; c < 3; ++c) faces_of[fill[mesh->indices[3 * f + c]]++] = uint32_t(f);
  }
  std::vector<Vec3d> start(nv), moved;
  for (uint32_t v = 0; v < nv; ++v) start[v] = p(v);
  if (device) {
    VPR_RETURN_IF_ERROR(device->relax(RelaxMesh{mesh, &face_start, &faces_of, &freedom, &source, &line}, &moved));
    if (moved.size() != nv) return internal_error("relaxation: the device moved another mesh");
  } else {
    moved.resize(nv);
    const RelaxView view{start.data(),    mesh->indices.data(),     face_start.data(),
                         faces_of.data(), freedom.data(),           source.data(),
                         line.data(),     surface.positions.data(), surface.indices.data()};
    auto lists = [&](uint32_t cell) { return cell_faces[cell].list(); };
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 256), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t v = r.begin(); v != r.end(); ++v) moved[v] = relax_move(view, lists, v);
    });
  }
  auto same = [](const Vec3d& a, const Vec3d& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
  auto put = [&](uint32_t v, const Vec3d& x) {
    mesh->positions[3 * v] = float(x.x);
    mesh->positions[3 * v + 1] = float(x.y);
    mesh->positions[3 * v + 2] = float(x.z);
  };
  for (uint32_t v = 0; v < nv; ++v) put(v, moved[v]);
  for (bool changed = true; changed;) {
    changed = false;
    for (size_t f = 0; f < nf; ++f) {
      const uint32_t* t = &mesh->indices[3 * f];
      const Vec3d before = cross(start[t[1]] - start[t[0]], start[t[2]] - start[t[0]]);
      const Vec3d after = cross(p(t[1]) - p(t[0]), p(t[2]) - p(t[0]));
      if (!(norm2(before) > 0) || dot(after, before) > 0) continue;
      for (int k = 0; k < 3; ++k)
        if (!same(moved[t[k]], start[t[k]])) {
          moved[t[k]] = start[t[k]];
          put(t[k], start[t[k]]);
          changed = true;
        }
    }
  }
  return Status::Ok();
}

}  // namespace

bool per_cell_sums(int option) {
  return option > 0 || (option < 0 && tbb::this_task_arena::max_concurrency() >= 8);
}

DualSurface dual_surface(const Mesh& surface, const MeshEdges& edges, bool with_planes) {
  const size_t nv = surface.vertex_count(), nf = surface.face_count();
  DualSurface facts;
  std::vector<char>& on_boundary = facts.on_boundary;
  on_boundary.assign(3 * nf, 0);
  auto face_normal = [&](size_t f) {
    const uint32_t* t = &surface.indices[3 * f];
    const Vector3d a = eig(load3d(surface.positions.data(), t[0]));
    return (eig(load3d(surface.positions.data(), t[1])) - a).cross(eig(load3d(surface.positions.data(), t[2])) - a).normalized();
  };
  {
    // Each edge's faces, from the surface's edge rows (entry(min, max)
    // numbers an edge once): the first two faces in face order.
    std::vector<uint32_t> edge_of(3 * nf);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nf, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f)
        for (int c = 0; c < 3; ++c) {
          const uint32_t u = surface.indices[3 * f + c], w = surface.indices[3 * f + (c + 1) % 3];
          const uint32_t e = edges.entry(std::min(u, w), std::max(u, w));  // UINT32_MAX: a repeated corner
          edge_of[3 * f + c] = e;
          on_boundary[3 * f + c] = e != UINT32_MAX && edges.faces[e] == 1;
        }
    });
    // The corners in order, each edge's first two faces kept: by ranges of
    // edge entries, one per thread (vertex_ranges.h), each edge's corners
    // still met in corner order.
    std::vector<std::array<uint32_t, 2>> faces_of(edges.neighbor.size(), {UINT32_MAX, UINT32_MAX});
    in_vertex_ranges(faces_of.size(), [&](uint32_t lo, uint32_t hi) {
      for (size_t i = 0; i < 3 * nf; ++i) {
        const uint32_t e = edge_of[i];
        if (e < lo || e >= hi) continue;  // another range's, or no edge
        auto& two = faces_of[e];
        (two[0] == UINT32_MAX ? two[0] : two[1]) = uint32_t(i / 3);
      }
    });
    // A sharp edge: faces more than 30 degrees apart (the flips' crease),
    // tested per edge in parallel, with each face's unit normal made once
    // (the planes' normal; a face of no area, whose plane has none, its
    // normal as the test made it).
    std::vector<Vec3d> normal;
    std::vector<double> area;
    face_planes(surface, &normal, &area);
    auto unit_normal = [&](uint32_t f) { return area[f] > 0 ? eig(normal[f]) : face_normal(f); };
    std::vector<char> sharp(edges.neighbor.size(), 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 2048), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t u = r.begin(); u != r.end(); ++u)
        for (uint32_t e = edges.offset[u]; e < edges.offset[u + 1]; ++e) {
          if (edges.neighbor[e] <= u || edges.faces[e] != 2 || faces_of[e][1] == UINT32_MAX) continue;
          sharp[e] = unit_normal(faces_of[e][0]).dot(unit_normal(faces_of[e][1])) < kCreaseCos;
        }
    });
    // The sharp entries in row order (few: a scan's creases, a CAD model's
    // edges).
    facts.sharp_edges = collect_in_order<std::pair<uint32_t, uint32_t>>(
        nv, [&](size_t u, std::vector<std::pair<uint32_t, uint32_t>>* out) {
          for (uint32_t e = edges.offset[u]; e < edges.offset[u + 1]; ++e)
            if (sharp[e]) out->push_back({uint32_t(u), edges.neighbor[e]});
        }, 4096);
    if (with_planes) {
      facts.normal = std::move(normal);
      facts.area = std::move(area);
    }
  }
  return facts;
}

Status mesh_clusters(const Mesh& surface, const std::vector<uint32_t>& label, uint32_t count, Mesh* out,
                     std::vector<uint32_t>* cell_of_vertex, ClusterMeshStats* stats,
                     const ClusterMeshOptions& options) {
  return mesh_clusters(surface, mesh_edges(surface), label, count, out, cell_of_vertex, stats, options);
}

Status mesh_clusters(const Mesh& surface, const MeshEdges& edges, const std::vector<uint32_t>& label, uint32_t count,
                     Mesh* out, std::vector<uint32_t>* cell_of_vertex, ClusterMeshStats* stats,
                     const ClusterMeshOptions& options) {
  const size_t nv = surface.vertex_count(), nf = surface.face_count();
  if (label.size() != nv) return invalid_argument("cluster mesh: one label per vertex expected");
  if (edges.vertex_count() != nv) return invalid_argument("cluster mesh: edges of another mesh");
  StepMarks marks("dual");
  ClusterMeshStats st;
  st.cells = count;

  // The surface's own facts (dual_surface), made beside the CVT or here.
  const bool per_cell = per_cell_sums(options.per_cell_sums);
  DualSurface made;
  if (!options.surface_facts) made = dual_surface(surface, edges, true);
  const DualSurface& facts = options.surface_facts ? *options.surface_facts : made;
  marks.mark("facts");
  if (facts.on_boundary.size() != 3 * nf) return invalid_argument("cluster mesh: the facts of another surface");
  const std::vector<char>& on_boundary = facts.on_boundary;
  // Per cell, the length of its input's sharp edges: each sharp edge's
  // length towards the cells of both its ends, in (u, w) order.
  std::vector<double> sharp_length(count, 0.0);
  for (const auto& [u, w] : facts.sharp_edges) {
    if (u >= nv || w >= nv) return invalid_argument("cluster mesh: the facts of another surface (a sharp edge's end)");
    const double len = (eig(load3d(surface.positions.data(), u)) - eig(load3d(surface.positions.data(), w))).norm();
    if (label[u] != UINT32_MAX) sharp_length[label[u]] += len;
    if (label[w] != UINT32_MAX && label[w] != label[u]) sharp_length[label[w]] += len;
  }
  std::vector<char> boundary_cell(count, 0);
  marks.mark("sharp_lengths");

  // Quadrics, centroids (area-weighted) and the faces touching each cell:
  // per face (of positive area) in face order, its plane once into each cell
  // among its corners, each corner's share of its area into that corner's
  // cell, and through an input boundary edge a plane across the surface (it
  // keeps the vertex on the boundary line; weighted like a face: length^2)
  // into the cells of the edge's ends. On many cores the faces' normals come
  // first in parallel and then each cell sums its own faces' terms, in face
  // order as the loop does: the same bits (a cell's faces lie scattered in
  // memory, so on a few cores the one loop is faster).
  std::vector<Quadric> quadric(count);
  std::vector<Vector3d> centroid(count, Vector3d::Zero());
  std::vector<double> weight(count, 0.0);
  std::vector<CellFaces> cell_faces(count);
  auto corner = [&](const uint32_t* t, int k) { return eig(load3d(surface.positions.data(), t[k])); };
  // fn(cell) for each cell among face t's corners, once each, in corner order.
  auto for_each_cell_of = [&](const uint32_t* t, auto&& fn) {
    uint32_t seen[3] = {UINT32_MAX, UINT32_MAX, UINT32_MAX};
    for (int k = 0; k < 3; ++k) {
      const uint32_t cell = label[t[k]];
      if (cell == UINT32_MAX || cell == seen[0] || cell == seen[1]) continue;
      seen[k] = cell;
      fn(cell);
    }
  };
  // Face f's terms into the cells in [lo, hi); list: the face is also added
  // to those cells' lists.
  auto add_face = [&](size_t f, const Vector3d& n, double area, uint32_t lo, uint32_t hi, bool list) {
    auto in = [&](uint32_t cell) { return cell >= lo && cell < hi; };
    const uint32_t* t = &surface.indices[3 * f];
    const Vector3d a = corner(t, 0);
    for_each_cell_of(t, [&](uint32_t cell) {
      if (!in(cell)) return;
      quadric[cell].add_plane(n, a, area);
      if (list) cell_faces[cell].face.push_back(uint32_t(f));
    });
    for (int k = 0; k < 3; ++k) {
      const uint32_t cell = label[t[k]];
      if (cell == UINT32_MAX) continue;
      if (in(cell)) {
        centroid[cell] += corner(t, k) * (area / 3);
        weight[cell] += area / 3;
      }
      const uint32_t u = t[k], w = t[(k + 1) % 3];
      if (on_boundary[3 * f + k]) {
        const Vector3d pu = eig(load3d(surface.positions.data(), u)), pw = eig(load3d(surface.positions.data(), w));
        const Vector3d e = pw - pu;
        const Vector3d across = e.cross(n).normalized();
        for (uint32_t end : {u, w}) {
          const uint32_t ec = label[end];
          if (ec == UINT32_MAX || !in(ec)) continue;
          boundary_cell[ec] = 1;
          quadric[ec].add_plane(across, pu, e.squaredNorm());
        }
      }
    }
  };
  if (!per_cell) {
    // The one loop by ranges of cells (core/vertex_ranges.h): each range's
    // thread reads every face in order and adds only into its own cells, so
    // each cell gets the loop's terms in face order (the same bits on any
    // thread count) and two threads share what one did (igea at 10,000 on
    // 2 cores: 38 ms on one). The faces' planes are the facts' when made.
    const bool planes = facts.normal.size() == nf;
    in_vertex_ranges(
        count,
        [&](uint32_t lo, uint32_t hi) {
          for (size_t f = 0; f < nf; ++f) {
            const uint32_t* t = &surface.indices[3 * f];
            bool mine = false;
            for (int k = 0; k < 3; ++k) mine = mine || (label[t[k]] >= lo && label[t[k]] < hi);
            if (!mine) continue;
            Vector3d n;
            double area;
            if (planes) {
              n = eig(facts.normal[f]);
              area = facts.area[f];
            } else {
              face_plane(surface, f, &n, &area);
            }
            if (area > 0) add_face(f, n, area, lo, hi, true);
          }
        },
        256);
  } else {
    std::vector<Vec3d> normal_made;
    std::vector<double> area_made;
    if (facts.normal.size() != nf) face_planes(surface, &normal_made, &area_made);
    const std::vector<Vec3d>& normal = facts.normal.size() == nf ? facts.normal : normal_made;
    const std::vector<double>& face_area = facts.normal.size() == nf ? facts.area : area_made;
    // Each cell's faces, in face order: a counting sort of the faces by
    // their corners' cells (core/bucket_sort.h), each cell's then sorted;
    // then each cell's terms from its list.
    std::vector<uint32_t> list_start, list_face;
    bucket_sort_each<uint32_t>(
        nf, count,
        [&](size_t f, auto&& add) {
          if (face_area[f] > 0)
            for_each_cell_of(&surface.indices[3 * f], [&](uint32_t cell) {
              if (cell < count) add(cell);
            });
        },
        [](size_t f) { return uint32_t(f); }, std::less<uint32_t>(), &list_start, &list_face);
    marks.mark("cell_lists");
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, count, 16), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t cell = r.begin(); cell != r.end(); ++cell) {
        std::vector<uint32_t>& faces = cell_faces[cell].face;
        faces.assign(list_face.begin() + list_start[cell], list_face.begin() + list_start[cell + 1]);
        for (uint32_t f : faces) add_face(f, eig(normal[f]), face_area[f], cell, cell + 1, false);
      }
    });
  }
  marks.mark("quadrics");
  // The projections onto the cells' faces: on the device when one is given
  // and takes the lists (flattened for it), else here, where each face's
  // bounding sphere prunes the searches.
  std::unique_ptr<DualProjector> device;
  if (options.device_projector) {
    std::vector<uint32_t> list_start(size_t(count) + 1, 0), list_face;
    for (uint32_t cell = 0; cell < count; ++cell)
      list_start[cell + 1] = list_start[cell] + uint32_t(cell_faces[cell].face.size());
    list_face.resize(list_start[count]);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, count, 256), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t cell = r.begin(); cell != r.end(); ++cell)
        std::copy(cell_faces[cell].face.begin(), cell_faces[cell].face.end(), list_face.begin() + list_start[cell]);
    });
    auto made = options.device_projector(CellFaceLists{&surface, &list_start, &list_face});
    if (made.ok())
      device = std::move(*made);
    else
      st.projection_fallback = made.status().to_string();
  }
  bool spheres_made = false;
  auto make_spheres = [&] {
    if (spheres_made) return;
    spheres_made = true;
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, count, 64), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t cell = r.begin(); cell != r.end(); ++cell) {
        CellFaces& cf = cell_faces[cell];
        cf.sphere.resize(cf.face.size());
        for (size_t i = 0; i < cf.face.size(); ++i)
          cf.sphere[i] = face_sphere(surface.positions.data(), surface.indices.data(), cf.face[i]);
      }
    });
  };
  // A device that fails leaves the rest to the host, from the same state.
  auto host_from_now = [&](const Status& failed) {
    st.projection_fallback = failed.to_string();
    device.reset();
    make_spheres();
  };
  if (!device) make_spheres();

  marks.mark("projector");
  // An input boundary loop met by exactly three cells: their triangle would
  // cap the hole (a small rim closes), so it is not made.
  std::set<std::array<uint32_t, 3>> caps;
  {
    std::vector<uint32_t> parent(nv);
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](uint32_t v) {
      while (parent[v] != v) v = parent[v] = parent[parent[v]];
      return v;
    };
    std::vector<char> on_loop(nv, 0);
    const std::vector<uint32_t> boundary_corners = collect_in_order<uint32_t>(
        3 * nf, [&](size_t i, std::vector<uint32_t>* out) {
          if (on_boundary[i]) out->push_back(uint32_t(i));
        });
    for (const uint32_t i : boundary_corners) {
      const uint32_t u = surface.indices[i], w = surface.indices[i - i % 3 + (i % 3 + 1) % 3];
      on_loop[u] = on_loop[w] = 1;
      parent[find(u)] = find(w);
    }
    std::map<uint32_t, std::set<uint32_t>> cells_of_loop;
    for (uint32_t v = 0; v < nv; ++v)
      if (on_loop[v] && label[v] != UINT32_MAX) cells_of_loop[find(v)].insert(label[v]);
    for (const auto& [root, cells] : cells_of_loop)
      if (cells.size() == 3) {
        auto it = cells.begin();
        const uint32_t a = *it++, b = *it++, c = *it;
        caps.insert({a, b, c});
      }
  }
  // Dual triangles: one per cell triple (the first face's orientation).
  // The faces whose corners lie in three cells (a few in a hundred), found
  // in parallel, then taken in face order.
  const std::vector<std::array<uint32_t, 3>> triples = collect_in_order<std::array<uint32_t, 3>>(
      nf, [&](size_t f, std::vector<std::array<uint32_t, 3>>* out) {
        const uint32_t* t = &surface.indices[3 * f];
        const uint32_t a = label[t[0]], b = label[t[1]], c = label[t[2]];
        if (a == b || b == c || a == c || a == UINT32_MAX || b == UINT32_MAX || c == UINT32_MAX) return;
        out->push_back({a, b, c});
      });
  // Each triple's first face kept, unless its loop caps a hole: the
  // triples sorted with their face order in parallel, the first of each run
  // marked, then taken in face order.
  std::vector<std::pair<std::array<uint32_t, 3>, uint32_t>> keyed(triples.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, triples.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      keyed[i] = {triples[i], uint32_t(i)};
      std::sort(keyed[i].first.begin(), keyed[i].first.end());
    }
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());  // distinct pairs: one order on any thread count
  std::vector<char> first(triples.size(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, keyed.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      first[keyed[i].second] = (i == 0 || keyed[i].first != keyed[i - 1].first) && !caps.count(keyed[i].first);
  });
  std::vector<std::array<uint32_t, 3>> tris = collect_in_order<std::array<uint32_t, 3>>(
      triples.size(), [&](size_t i, std::vector<std::array<uint32_t, 3>>* out) {
        if (first[i]) out->push_back(triples[i]);
      }, 4096);

  st.holes_closed += close_dual_holes(&tris, [&](uint32_t cell) { return boundary_cell[cell] != 0; },
                                      &st.boundary_loops);

  marks.mark("caps_triples_holes");
  // Vertex positions: quadric minimum about the centroid, then onto the
  // cell's triangles; each cell on its own, so in parallel.
  std::vector<float> points(3 * size_t(count), 0.0f);
  std::vector<char> feature(count, 0);  // the cell covers a crease or corner
  std::vector<char> pinned_directions(count, 0);
  std::vector<Vec3d> line(count);                           // a crease cell's line direction
  std::vector<Vec3d> solved(count), centre(count), placed;  // the quadric's minimum, the centroid, on the faces
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, count, 256), [&](const tbb::blocked_range<uint32_t>& range) {
    for (uint32_t cell = range.begin(); cell != range.end(); ++cell) {
      if (!(weight[cell] > 0)) continue;
      const Vector3d c = centroid[cell] / weight[cell];
      Eigen::SelfAdjointEigenSolver<Matrix3d> solver(quadric[cell].a);
      const Vector3d lambda = solver.eigenvalues();
      const Matrix3d u = solver.eigenvectors();
      const Vector3d r = quadric[cell].b - quadric[cell].a * c;
      Vector3d x = c;
      const double top = lambda.cwiseAbs().maxCoeff();
      // Directions the faces pin down: the dominant normal always; a second and
      // a third only where the cell covers a crease or corner (an eigenvalue
      // over 5% of the largest: a cell bent by 20 degrees gives about 1%).
      int pinned = 0;
      for (int k = 0; k < 3; ++k)
        if (std::abs(lambda[k]) > 0.05 * top) x += u.col(k) * (u.col(k).dot(r) / lambda[k]), ++pinned;
      // A crease or corner: pinned in two or three directions by faces that
      // meet at sharp edges crossing the cell (at least half its width of
      // them; a smoothly bent cell pins a second direction too, and a scan's
      // noise has short sharp edges).
      feature[cell] = pinned >= 2 && sharp_length[cell] > 0.5 * std::sqrt(weight[cell]);
      pinned_directions[cell] = char(pinned);
      if (pinned == 2) line[cell] = {u(0, 0), u(1, 0), u(2, 0)};  // eigenvalues ascend: the free direction first
      solved[cell] = {x.x(), x.y(), x.z()};
      centre[cell] = {c.x(), c.y(), c.z()};
    }
  });
  marks.mark("solve");
  if (device) {
    const Status placed_there = device->place(solved, centre, &placed);
    if (!placed_there.ok()) host_from_now(placed_there);
  }
  if (!device) {
    placed.assign(count, Vec3d{});
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, count, 256), [&](const tbb::blocked_range<uint32_t>& range) {
      for (uint32_t cell = range.begin(); cell != range.end(); ++cell) {
        if (!(weight[cell] > 0)) continue;
        Vec3d best = centre[cell];
        double best_d = INFINITY;
        const FaceList faces = cell_faces[cell].list();
        nearest_on_lists(solved[cell], &faces, 1, surface.positions.data(), surface.indices.data(), &best, &best_d);
        placed[cell] = best;
      }
    });
  }
  for (uint32_t cell = 0; cell < count; ++cell)
    if (weight[cell] > 0) {
      points[3 * size_t(cell)] = float(placed[cell].x);
      points[3 * size_t(cell) + 1] = float(placed[cell].y);
      points[3 * size_t(cell) + 2] = float(placed[cell].z);
    }

  marks.mark("place");
  // Two cells can land on one point of the input, or within rounding of it
  // (a corner of a face both touch): a needle of zero length and two
  // degenerate triangles that no later step moves apart. In cell order, a
  // cell within `near` (a thousandth of the mean spacing) of an earlier
  // cell's point moves to the nearest of its own elements that is clear of
  // every point kept so far (each element lies in one cell; elements are a
  // third of a spacing apart, so one is, unless all are taken).
  {
    double area = 0;
    for (uint32_t cell = 0; cell < count; ++cell) area += weight[cell];
    const double near = 1e-3 * std::sqrt(area / std::max<uint32_t>(count, 1));
    std::unordered_map<uint64_t, std::vector<Vector3d>> grid;  // kept points by grid cell of side `near`
    auto key = [&](const Vector3d& p, int dx, int dy, int dz) {
      const int64_t i = int64_t(std::floor(p.x() / near)) + dx, j = int64_t(std::floor(p.y() / near)) + dy,
                    k = int64_t(std::floor(p.z() / near)) + dz;
      return uint64_t(i * 73856093) ^ uint64_t(j * 19349663) ^ uint64_t(k * 83492791);
    };
    auto clear = [&](const Vector3d& p) {
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = grid.find(key(p, dx, dy, dz));
            if (it == grid.end()) continue;
            for (const Vector3d& q : it->second)
              if ((q - p).squaredNorm() < near * near) return false;
          }
      return true;
    };
    auto keep = [&](const Vector3d& p) { grid[key(p, 0, 0, 0)].push_back(p); };
    auto point = [&](uint32_t cell) {
      return Vector3d(points[3 * cell], points[3 * cell + 1], points[3 * cell + 2]);
    };
    std::vector<uint32_t> clashing;
    if (near > 0 && std::isfinite(near) && any_within(points, weight, near))
      for (uint32_t cell = 0; cell < count; ++cell) {
        if (!(weight[cell] > 0)) continue;
        if (clear(point(cell))) keep(point(cell));
        else clashing.push_back(cell);
      }
    if (!clashing.empty()) {
      std::map<uint32_t, std::vector<uint32_t>> elements;  // of the clashing cells
      for (uint32_t cell : clashing) elements[cell];
      for (uint32_t v = 0; v < nv; ++v)
        if (label[v] != UINT32_MAX && elements.count(label[v])) elements[label[v]].push_back(v);
      for (uint32_t cell : clashing) {
        const Vector3d at = point(cell);
        std::vector<std::pair<double, uint32_t>> by_distance;
        for (uint32_t v : elements[cell])
          by_distance.push_back({(eig(load3d(surface.positions.data(), v)) - at).squaredNorm(), v});
        std::sort(by_distance.begin(), by_distance.end());
        for (const auto& [d, v] : by_distance) {
          const Vector3d q = eig(load3d(surface.positions.data(), v));
          if (!clear(q)) continue;
          for (int k = 0; k < 3; ++k) points[3 * size_t(cell) + k] = surface.positions[3 * size_t(v) + k];
          keep(q);
          ++st.points_separated;
          break;
        }
      }
    }
  }

  marks.mark("clashes");
  if (tris.empty()) return invalid_argument("cluster mesh: the cells form no triangle");
  std::vector<uint32_t> flat;
  flat.reserve(3 * tris.size());
  for (const auto& t : tris) flat.insert(flat.end(), t.begin(), t.end());
  // Orientation, non-manifold splits and unused cells: the soup repair; its
  // hole filling and bridge removal are off (holes were handled above).
  MeshingOptions repair;
  repair.max_hole_edges = 0;
  repair.max_edge_ratio = 1e30;
  std::vector<uint32_t> source;
  VPR_RETURN_IF_ERROR(repair_triangle_soup(points.data(), count, flat.data(), tris.size(), repair, out, &source,
                                           &st.repair));
  marks.mark("repair");
  // The repair splits non-manifold vertices, which can open a hole the first
  // pass could not walk: once more on the repaired mesh.
  {
    std::vector<std::array<uint32_t, 3>> faces(out->face_count());
    for (size_t f = 0; f < faces.size(); ++f)
      faces[f] = {out->indices[3 * f], out->indices[3 * f + 1], out->indices[3 * f + 2]};
    size_t loops = 0;
    const size_t closed =
        close_dual_holes(&faces, [&](uint32_t v) { return boundary_cell[source[v]] != 0; }, &loops);
    if (closed > 0) {
      st.holes_closed += closed;
      out->indices.clear();
      for (const auto& t : faces) out->indices.insert(out->indices.end(), t.begin(), t.end());
    }
    st.boundary_loops = loops;
  }
  marks.mark("holes_again");
  drop_slivers(out, &source);
  drop_extra_pieces(out, &source, surface, label);
  marks.mark("drops");
  // The flips' edge rows, kept from run to run: between them only the
  // vertices move (the relaxation, the fit).
  FlipRowsKept flip_rows;
  delaunay_flips(out, &flip_rows);
  marks.mark("flips");
  std::vector<char> output_boundary(out->vertex_count(), 0);
  {
    // The ends of every edge not used by exactly two faces: the undirected
    // edges sorted (in parallel), each run's length its uses.
    std::vector<uint64_t> uses(out->indices.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, out->face_count(), 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t f = r.begin(); f != r.end(); ++f)
        for (int c = 0; c < 3; ++c) uses[3 * f + c] = key2(out->indices[3 * f + c], out->indices[3 * f + (c + 1) % 3]);
    });
    tbb::parallel_sort(uses.begin(), uses.end());
    for (size_t i = 0, j; i < uses.size(); i = j) {
      for (j = i + 1; j < uses.size() && uses[j] == uses[i];) ++j;
      if (j - i != 2) output_boundary[uint32_t(uses[i] >> 32)] = output_boundary[uint32_t(uses[i])] = 1;
    }
  }
  marks.mark("output_boundary");
  if (options.relax_rounds > 0) {
    std::vector<Freedom> freedom(out->vertex_count(), Freedom::kFree);
    for (size_t v = 0; v < freedom.size(); ++v) {
      const uint32_t cell = source[v];
      if (boundary_cell[cell] || output_boundary[v] || (feature[cell] && pinned_directions[cell] >= 3))
        freedom[v] = Freedom::kHeld;
      else if (feature[cell]) freedom[v] = Freedom::kAlongLine;
    }
    for (int round = 0; round < options.relax_rounds; ++round) {
      Status relaxed = relax_tangentially(out, source, freedom, line, surface, cell_faces, device.get());
      if (!relaxed.ok() && device) {
        host_from_now(relaxed);
        relaxed = relax_tangentially(out, source, freedom, line, surface, cell_faces, nullptr);
      }
      VPR_RETURN_IF_ERROR(relaxed);
      delaunay_flips(out, &flip_rows);
    }
  }
  marks.mark("relax_flips");
  {
    std::vector<char> on_feature(out->vertex_count(), 0);
    std::vector<Vector3d> vertex_line(out->vertex_count(), Vector3d::Zero());
    for (size_t v = 0; v < on_feature.size(); ++v) {
      on_feature[v] = feature[source[v]];
      if (feature[source[v]] && pinned_directions[source[v]] == 2) vertex_line[v] = eig(line[source[v]]);
    }
    restore_crease_edges(out, on_feature, vertex_line, &flip_rows);
  }
  marks.mark("creases");
  {
    // Held: input boundary, crease and corner cells, and any vertex on a
    // boundary of the output (its one-sided fit would pull the rim inwards).
    std::vector<char> pinned(out->vertex_count(), 0), held(out->vertex_count(), 0);
    for (size_t v = 0; v < held.size(); ++v)
      pinned[v] = boundary_cell[source[v]] || feature[source[v]] || output_boundary[v];
    // Their neighbours too: a triangle from a vertex on one side of a crease
    // over a crease vertex to the other side cuts the crease, and the
    // samples it misses would pull the vertex off its (often flat) face.
    for (size_t f = 0; f < out->face_count(); ++f) {
      const uint32_t* t = &out->indices[3 * f];
      if (pinned[t[0]] || pinned[t[1]] || pinned[t[2]]) held[t[0]] = held[t[1]] = held[t[2]] = 1;
    }
    VPR_RETURN_IF_ERROR(fit_offsets(surface, label, source, held, options.offset, out, &st.offset));
  }
  marks.mark("fit");
  flip_caps(out, &flip_rows);
  marks.mark("flip_caps");
  st.projected_on_device = device != nullptr;
  st.cells_unused = count - out->vertex_count();
  if (cell_of_vertex) *cell_of_vertex = std::move(source);
  if (stats) *stats = st;
  return Status::Ok();
}

}  // namespace vpr
