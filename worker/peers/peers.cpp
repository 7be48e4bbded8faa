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
