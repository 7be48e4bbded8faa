// The peer registry and what the peers share.
#include "peers.h"

#include <cstring>
#include <unordered_map>

#include "peers_internal.h"

namespace vpr::peers {

Mesh compact(const std::vector<float>& positions, const std::vector<uint32_t>& indices) {
  constexpr uint32_t kUnused = UINT32_MAX;
  std::vector<uint32_t> remap(positions.size() / 3, kUnused);
  Mesh out;
  out.indices.reserve(indices.size());
  for (uint32_t i : indices) {
    if (remap[i] == kUnused) {
      remap[i] = uint32_t(out.positions.size() / 3);
      out.positions.insert(out.positions.end(), &positions[3 * size_t(i)], &positions[3 * size_t(i)] + 3);
    }
    out.indices.push_back(remap[i]);
  }
  return out;
}

Mesh weld_exact(const Mesh& mesh) {
  struct Key {
    uint32_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      return (size_t(k.x) * 73856093u) ^ (size_t(k.y) * 19349663u) ^ (size_t(k.z) * 83492791u);
    }
  };
  std::unordered_map<Key, uint32_t, KeyHash> ids;
  ids.reserve(mesh.vertex_count());
  std::vector<uint32_t> id(mesh.vertex_count());
  Mesh out;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    Key k;
    std::memcpy(&k, &mesh.positions[3 * v], sizeof k);
    auto [it, added] = ids.emplace(k, uint32_t(ids.size()));
    if (added) out.positions.insert(out.positions.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
    id[v] = it->second;
  }
  out.indices.reserve(mesh.indices.size());
  for (uint32_t i : mesh.indices) out.indices.push_back(id[i]);
  out.origin = mesh.origin;
  out.scale = mesh.scale;
  return out;
}

Status check_input(const Mesh& input, uint32_t target_vertices, const char* method) {
  if (target_vertices == 0) return invalid_argument(std::string(method) + ": the target vertex count must be positive");
  Status s = validate_mesh(input);
  if (!s.ok()) return invalid_argument(std::string(method) + ": " + s.message());
  return Status::Ok();
}

const std::vector<Peer>& all_peers() {
  static const std::vector<Peer> peers = {
      {"OpenMesh QEM", [](const Mesh& m, uint32_t t) { return openmesh_quadric(m, t); }},
      {"meshoptimizer", [](const Mesh& m, uint32_t t) { return meshopt_simplify(m, t); }},
      {"CGAL isotropic", [](const Mesh& m, uint32_t t) { return cgal_isotropic_remesh(m, t); }},
  };
  return peers;
}

}  // namespace vpr::peers
