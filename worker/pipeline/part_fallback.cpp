#include "pipeline/part_fallback.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <utility>

#include "core/mesh_parts.h"
#include "core/step_marks.h"
#include "core/vec3.h"
#include "peers/peers.h"
#include "pipeline/triangle_shape.h"
#include "surface/closest_point.h"

namespace vpr {

SurfaceParts surface_parts(const Mesh& surface, const MeshEdges& edges) {
  SurfaceParts sp;
  const size_t nv = surface.vertex_count();
  size_t parts = 0;
  sp.face_part = face_parts(surface, &parts);
  sp.parts = parts;
  const std::vector<uint32_t>& face_part = sp.face_part;
  std::vector<uint32_t>& vertex_part = sp.vertex_part;
  vertex_part.assign(nv, UINT32_MAX);
  std::vector<int64_t> part_face_count(parts, 0);
  for (size_t f = 0; f < surface.face_count(); ++f) {
    if (face_part[f] == UINT32_MAX) continue;
    ++part_face_count[face_part[f]];
    for (int k = 0; k < 3; ++k) vertex_part[surface.indices[3 * f + k]] = face_part[f];
  }
  // Closed input parts (every edge in two faces) and their Euler
  // characteristic, counted in one pass over the surface's rows (a sort of
  // its million corners, as the output part's shape once was counted, cost igea
  // a second).
  // Open parts too, where they are manifolds (every edge in one or two
  // faces): their boundary loops, counted as the pieces of their border
  // edges' graph.
  std::vector<char>& closed = sp.closed;
  std::vector<char>& manifold = sp.manifold;
  std::vector<int64_t>& euler = sp.euler;
  closed.assign(parts, 1);
  manifold.assign(parts, 1);
  euler.assign(parts, 0);
  std::vector<uint32_t> border_root(nv);
  std::iota(border_root.begin(), border_root.end(), 0u);
  auto root = [&](uint32_t x) {
    while (border_root[x] != x) x = border_root[x] = border_root[border_root[x]];
    return x;
  };
  std::vector<char> on_border(nv, 0);
  for (uint32_t u = 0; u < nv; ++u) {
    const uint32_t p = vertex_part[u];
    if (p == UINT32_MAX) continue;
    ++euler[p];
    for (uint32_t i = edges.offset[u]; i < edges.offset[u + 1]; ++i) {
      if (edges.faces[i] != 2) closed[p] = 0;
      if (edges.faces[i] > 2) manifold[p] = 0;
      if (edges.neighbor[i] > u) --euler[p];
      if (edges.faces[i] == 1) {
        on_border[u] = on_border[edges.neighbor[i]] = 1;
        const uint32_t a = root(u), b = root(edges.neighbor[i]);
        if (a != b) border_root[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  sp.loops.assign(parts, 0);
  for (uint32_t u = 0; u < nv; ++u)
    if (on_border[u] && root(u) == u && vertex_part[u] != UINT32_MAX) ++sp.loops[vertex_part[u]];
  for (uint32_t p = 0; p < parts; ++p) euler[p] += part_face_count[p];
  return sp;
}

Status replace_broken_parts(const Mesh& surface, const MeshEdges& edges, const std::vector<uint32_t>& label,
                            uint32_t target, Mesh* out, std::vector<uint32_t>* cell_of_vertex,
                            PartFallbackStats* stats) {
  if (label.size() != surface.vertex_count() || edges.vertex_count() != surface.vertex_count())
    return internal_error("part fallback: the surface, its cells and the output disagree");
  return replace_broken_parts(surface, edges, surface_parts(surface, edges), label, target, out, cell_of_vertex,
                              stats);
}

Status replace_broken_parts(const Mesh& surface, const MeshEdges& edges, const SurfaceParts& shapes,
                            const std::vector<uint32_t>& label, uint32_t target, Mesh* out,
                            std::vector<uint32_t>* cell_of_vertex, PartFallbackStats* stats) {
  *stats = {};
  const size_t nv = surface.vertex_count();
  if (label.size() != nv || edges.vertex_count() != nv || cell_of_vertex->size() != out->vertex_count() ||
      shapes.face_part.size() != surface.face_count() || shapes.vertex_part.size() != nv)
    return internal_error("part fallback: the surface, its cells and the output disagree");
  const size_t parts = shapes.parts;
  const std::vector<uint32_t>& face_part = shapes.face_part;
  const std::vector<uint32_t>& vertex_part = shapes.vertex_part;
  const std::vector<char>& closed = shapes.closed;
  const std::vector<char>& manifold = shapes.manifold;
  const std::vector<int64_t>& euler = shapes.euler;
  const std::vector<size_t>& loops = shapes.loops;
  StepMarks marks("part_fallback");
  uint32_t cells = 0;
  for (uint32_t l : label)
    if (l != UINT32_MAX) cells = std::max(cells, l + 1);
  std::vector<uint32_t> cell_part(cells, UINT32_MAX);
  std::vector<uint32_t> part_cells(parts, 0), first_cell(parts, 0);
  for (size_t v = 0; v < nv; ++v)
    if (label[v] != UINT32_MAX && vertex_part[v] != UINT32_MAX && cell_part[label[v]] == UINT32_MAX) {
      cell_part[label[v]] = vertex_part[v];
      if (part_cells[vertex_part[v]]++ == 0) first_cell[vertex_part[v]] = label[v];
    }
  // The output's faces by the part their cells lie in. A face whose corners'
  // cells lie in different parts (parts that share input vertices, e.g.
  // where a part that is not a manifold touches another, give cells that
  // span both) joins those parts in the output: neither can be cut out and
  // replaced alone, since the splice would leave the other part's faces
  // around the shared vertices in separate fans (a non-manifold vertex).
  marks.mark("cells");
  auto part_of_cell = [&](uint32_t c) { return c < cells ? cell_part[c] : UINT32_MAX; };
  std::vector<std::vector<std::array<uint32_t, 3>>> out_faces(parts);
  std::vector<char> joined(parts, 0);
  for (size_t f = 0; f < out->face_count(); ++f) {
    std::array<uint32_t, 3> corner_part{};
    for (int k = 0; k < 3; ++k) corner_part[size_t(k)] = part_of_cell((*cell_of_vertex)[out->indices[3 * f + k]]);
    const uint32_t p = corner_part[0];
    if (corner_part[1] != p || corner_part[2] != p)
      for (uint32_t q : corner_part)
        if (q != UINT32_MAX) joined[q] = 1;
    if (p != UINT32_MAX) out_faces[p].push_back({out->indices[3 * f], out->indices[3 * f + 1], out->indices[3 * f + 2]});
  }

  marks.mark("faces");
  struct Replacement {
    uint32_t part;
    Mesh mesh;
    std::vector<uint32_t> cell;
  };
  std::vector<Replacement> replacements;
  // Whole: a manifold in one piece with the input part's Euler
  // characteristic and boundary loops (closed when the part is).
  auto whole = [&](const TriangleShape& shape, uint32_t p) {
    return shape.manifold && shape.one_piece && shape.euler == euler[p] && shape.loops == loops[p] &&
           shape.closed_manifold == bool(closed[p]);
  };
  std::vector<uint32_t> rank;  // triangle_shape's table, shared by the parts
  for (uint32_t p = 0; p < parts; ++p) {
    if (!manifold[p]) continue;  // no shape to hold the dual to
    // A part the CVT gave no cell (the target too small for every part: the
    // cvt stage's note says so) has no dual by design, and no cell for a
    // replacement's vertices to take.
    if (part_cells[p] == 0) continue;
    ++(closed[p] ? stats->closed_parts : stats->open_parts);
    if (joined[p]) {  // broken (the input's parts are apart) and not replaceable alone
      ++stats->parts_left;
      continue;
    }
    const TriangleShape now = triangle_shape(out_faces[p], &rank);
    if (whole(now, p)) continue;
    // The part alone, compact, in the surface's frame.
    Mesh sub;
    sub.origin = surface.origin;
    sub.scale = surface.scale;
    std::vector<uint32_t> local(nv, UINT32_MAX), global;
    for (size_t f = 0; f < surface.face_count(); ++f) {
      if (face_part[f] != p) continue;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = surface.indices[3 * f + k];
        if (local[v] == UINT32_MAX) {
          local[v] = uint32_t(global.size());
          global.push_back(v);
          sub.positions.insert(sub.positions.end(), surface.positions.begin() + 3 * v, surface.positions.begin() + 3 * v + 3);
        }
        sub.indices.push_back(local[v]);
      }
    }
    // The part's share of the target (the cells may be more than the target
    // where the topology step could not merge enough of them away).
    const uint32_t share = uint32_t(std::lround(double(part_cells[p]) * std::min(1.0, double(target) / std::max(cells, 1u))));
    auto decimated = peers::openmesh_quadric(sub, std::max<uint32_t>(share, 4));
    std::vector<std::array<uint32_t, 3>> faces;
    if (decimated.ok())
      for (size_t f = 0; f < decimated->mesh.face_count(); ++f)
        faces.push_back({decimated->mesh.indices[3 * f], decimated->mesh.indices[3 * f + 1], decimated->mesh.indices[3 * f + 2]});
    // A decimation that is no better (it cannot keep the part's genus) is
    // not taken: the part stays as the dual made it. (Parts welded at single
    // vertices no longer reach here as one part: refine_surface splits such
    // vertices, surface/pinch_split.h.)
    if (!whole(triangle_shape(faces, &rank), p)) {
      ++stats->parts_left;
      continue;
    }
    // Each new vertex takes the cell of the nearest surface element.
    Replacement r{p, std::move(decimated->mesh), {}};
    const ClosestPointTree tree(sub);
    r.cell.resize(r.mesh.vertex_count(), 0);
    for (size_t v = 0; v < r.mesh.vertex_count(); ++v) {
      if (tree.empty()) break;
      const auto hit = tree.closest(load3d(r.mesh.positions.data(), v));
      const int corner = int(std::max_element(hit.barycentric.begin(), hit.barycentric.end()) - hit.barycentric.begin());
      const uint32_t c = label[global[sub.indices[3 * size_t(hit.face) + size_t(corner)]]];
      r.cell[v] = c < cells ? c : first_cell[p];  // every element of a part with cells has one; kept safe
    }
    replacements.push_back(std::move(r));
  }
  marks.mark("shapes");
  if (replacements.empty()) return Status::Ok();

  // Splice: the output without the replaced parts' faces and vertices, then
  // the decimated parts.
  std::vector<char> replaced(parts, 0);
  for (const Replacement& r : replacements) replaced[r.part] = 1;
  std::vector<char> keep_face(out->face_count(), 1), keep_vertex(out->vertex_count(), 0);
  for (size_t f = 0; f < out->face_count(); ++f) {
    const uint32_t p = part_of_cell((*cell_of_vertex)[out->indices[3 * f]]);
    keep_face[f] = p == UINT32_MAX || !replaced[p];
    if (keep_face[f])
      for (int k = 0; k < 3; ++k) keep_vertex[out->indices[3 * f + k]] = 1;
  }
  Mesh spliced;
  spliced.origin = out->origin;
  spliced.scale = out->scale;
  std::vector<uint32_t> cell, remap(out->vertex_count(), UINT32_MAX);
  for (size_t v = 0; v < out->vertex_count(); ++v)
    if (keep_vertex[v]) {
      remap[v] = uint32_t(cell.size());
      cell.push_back((*cell_of_vertex)[v]);
      spliced.positions.insert(spliced.positions.end(), out->positions.begin() + 3 * v, out->positions.begin() + 3 * v + 3);
    }
  for (size_t f = 0; f < out->face_count(); ++f)
    if (keep_face[f])
      for (int k = 0; k < 3; ++k) spliced.indices.push_back(remap[out->indices[3 * f + k]]);
  for (const Replacement& r : replacements) {
    const uint32_t base = uint32_t(cell.size());
    spliced.positions.insert(spliced.positions.end(), r.mesh.positions.begin(), r.mesh.positions.end());
    cell.insert(cell.end(), r.cell.begin(), r.cell.end());
    for (uint32_t i : r.mesh.indices) spliced.indices.push_back(base + i);
  }
  stats->parts_replaced = replacements.size();
  *out = std::move(spliced);
  *cell_of_vertex = std::move(cell);
  return Status::Ok();
}

}  // namespace vpr
