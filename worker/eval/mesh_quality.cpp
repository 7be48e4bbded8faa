// Angle statistics and combinatorial topology of a triangle soup. Everything is
// counted from the index array alone (no half-edge structure), because the
// meshes evaluated here may be non-manifold soups.
#include "eval/mesh_quality.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>
#include <vector>

#include "core/vec3.h"

namespace vpr {
namespace {

constexpr uint32_t kNone = UINT32_MAX;
constexpr double kPi = 3.14159265358979323846;

// Union-find with path halving; counts are all that is read from it, so the
// union order does not affect any result.
class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), uint32_t(0)); }
  uint32_t find(uint32_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<uint32_t> parent_;
};

uint64_t edge_key(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32) | b : (uint64_t(b) << 32) | a;
}

struct EdgeInfo {
  uint32_t first_face;  // the face later incident faces are joined to around both ends
  uint32_t faces;
};

// Everything but the welded counts.
MeshQuality unwelded_quality(const Mesh& mesh) {
  MeshQuality q;
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  const float* p = mesh.positions.data();
  const uint32_t* idx = mesh.indices.data();
  q.vertices = nv;
  q.faces = nf;

  std::vector<char> finite(nv);
  for (size_t v = 0; v < nv; ++v)
    finite[v] = std::isfinite(p[3 * v]) && std::isfinite(p[3 * v + 1]) && std::isfinite(p[3 * v + 2]);
  std::vector<char> valid(nf);
  for (size_t f = 0; f < nf; ++f) {
    valid[f] = idx[3 * f] < nv && idx[3 * f + 1] < nv && idx[3 * f + 2] < nv && finite[idx[3 * f]] &&
               finite[idx[3 * f + 1]] && finite[idx[3 * f + 2]];
    if (!valid[f]) ++q.invalid_faces;
  }

  // Angles. atan2(|u x v|, u . v) stays accurate for the near-0 and near-180
  // degree angles of slivers, where acos of the normalised dot product does not.
  double min_angle = 180.0;
  size_t angles = 0, below_30 = 0;
  for (size_t f = 0; f < nf; ++f) {
    if (!valid[f]) continue;
    const Vec3d c[3] = {load3d(p, idx[3 * f]), load3d(p, idx[3 * f + 1]), load3d(p, idx[3 * f + 2])};
    if (norm(cross(c[1] - c[0], c[2] - c[0])) == 0.0) {
      ++q.degenerate_faces;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const Vec3d u = c[(k + 1) % 3] - c[k], v = c[(k + 2) % 3] - c[k];
      const double deg = std::atan2(norm(cross(u, v)), dot(u, v)) * (180.0 / kPi);
      min_angle = std::min(min_angle, deg);
      below_30 += deg < 30.0;
      ++angles;
    }
  }
  if (angles > 0) {
    q.min_angle_deg = min_angle;
    q.share_angles_below_30 = double(below_30) / double(angles);
  }

  // Edges and fans. Corner 3f+k is face f at its k-th vertex. Two faces sharing
  // edge (u, w) are in one fan around u and one fan around w, so their corners
  // there are joined; a vertex whose corners end in more than one set is
  // non-manifold.
  std::unordered_map<uint64_t, EdgeInfo> edges;
  edges.reserve(3 * nf / 2 + 16);
  DisjointSets fans(3 * nf);
  DisjointSets vertex_sets(nv);
  DisjointSets face_sets(nf);  // faces joined across shared edges: sheets
  // First corner of face f at vertex v (v is one of its corners).
  auto corner_of = [&](uint32_t f, uint32_t v) {
    const uint32_t k = idx[3 * f] == v ? 0 : idx[3 * f + 1] == v ? 1 : 2;
    return 3 * f + k;
  };
  for (size_t f = 0; f < nf; ++f) {
    if (!valid[f]) continue;
    const uint32_t v[3] = {idx[3 * f], idx[3 * f + 1], idx[3 * f + 2]};
    vertex_sets.unite(v[0], v[1]);
    vertex_sets.unite(v[0], v[2]);
    // A face repeating a vertex is one corner there, and one incidence per distinct edge.
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b)
        if (v[a] == v[b]) fans.unite(uint32_t(3 * f + a), uint32_t(3 * f + b));
    uint64_t seen[3];
    int n_seen = 0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      if (a == b) continue;
      const uint64_t key = edge_key(a, b);
      if (std::find(seen, seen + n_seen, key) != seen + n_seen) continue;
      seen[n_seen++] = key;
      auto [it, inserted] = edges.try_emplace(key, EdgeInfo{uint32_t(f), 1});
      if (inserted) continue;
      ++it->second.faces;
      const uint32_t g = it->second.first_face;
      face_sets.unite(uint32_t(f), g);
      fans.unite(corner_of(uint32_t(f), a), corner_of(g, a));
      fans.unite(corner_of(uint32_t(f), b), corner_of(g, b));
    }
  }

  DisjointSets boundary_sets(nv);
  std::vector<char> on_boundary(nv, 0);
  for (const auto& [key, info] : edges) {
    if (info.faces > 2) ++q.non_manifold_edges;
    if (info.faces != 1) continue;
    ++q.boundary_edges;
    const uint32_t a = uint32_t(key >> 32), b = uint32_t(key);
    boundary_sets.unite(a, b);
    on_boundary[a] = on_boundary[b] = 1;
  }

  std::vector<uint32_t> fan_root(nv, kNone);
  std::vector<char> non_manifold(nv, 0), referenced(nv, 0);
  size_t valid_faces = 0;
  for (size_t f = 0; f < nf; ++f) {
    if (!valid[f]) continue;
    ++valid_faces;
    if (face_sets.find(uint32_t(f)) == f) ++q.sheets;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = idx[3 * f + k], root = fans.find(uint32_t(3 * f + k));
      referenced[v] = 1;
      if (fan_root[v] == kNone)
        fan_root[v] = root;
      else if (fan_root[v] != root)
        non_manifold[v] = 1;
    }
  }

  size_t referenced_count = 0;
  for (size_t v = 0; v < nv; ++v) {
    referenced_count += referenced[v];
    q.non_manifold_vertices += non_manifold[v];
    if (referenced[v] && vertex_sets.find(uint32_t(v)) == v) ++q.components;
    if (on_boundary[v] && boundary_sets.find(uint32_t(v)) == v) ++q.boundary_loops;
  }
  q.closed = valid_faces > 0 && q.boundary_edges == 0 && q.non_manifold_edges == 0;
  q.euler_characteristic = long(referenced_count) - long(edges.size()) + long(valid_faces);
  return q;
}

}  // namespace

MeshQuality mesh_quality(const Mesh& mesh) {
  MeshQuality q = unwelded_quality(mesh);
  q.welded_boundary_loops = q.boundary_loops;
  q.welded_components = q.components;
  q.welded_sheets = q.sheets;
  q.welded_closed = q.closed;
  const Mesh welded = weld_exact(mesh);
  if (welded.vertex_count() < mesh.vertex_count()) {
    const MeshQuality w = unwelded_quality(welded);
    q.welded_boundary_loops = w.boundary_loops;
    q.welded_components = w.components;
    q.welded_sheets = w.sheets;
    q.welded_closed = w.closed;
  }
  return q;
}

}  // namespace vpr
