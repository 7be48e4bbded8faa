// Peer: OpenMesh's quadric decimater (Garland and Heckbert 1997, QEM), the
// decimater a user would pick instead of vpremesh.
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <string>

#include "peers.h"
#include "peers_internal.h"

namespace vpr::peers {
namespace {
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;
}

StatusOr<PeerResult> openmesh_quadric(const Mesh& unwelded, uint32_t target_vertices) {
  if (Status s = check_input(unwelded, target_vertices, "OpenMesh QEM"); !s.ok()) return s;
  const auto start = Clock::now();
  const Mesh input = weld_exact(unwelded);
  omerr().disable();  // one line per refused face otherwise; we count them instead
  OmMesh mesh;
  std::vector<OmMesh::VertexHandle> vh(input.vertex_count());
  for (size_t v = 0; v < input.vertex_count(); ++v)
    vh[v] =
        mesh.add_vertex(OmMesh::Point(input.positions[3 * v], input.positions[3 * v + 1], input.positions[3 * v + 2]));
  size_t refused = 0;
  for (size_t f = 0; f < input.face_count(); ++f) {
    const uint32_t* t = &input.indices[3 * f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++refused;
      continue;
    }
    refused += !mesh.add_face(vh[t[0]], vh[t[1]], vh[t[2]]).is_valid();
  }
  if (mesh.n_faces() == 0) return invalid_argument("OpenMesh QEM: OpenMesh accepted none of the mesh's faces");
  // Vertices of refused faces would stay as isolated points and count towards the target.
  mesh.request_vertex_status();
  mesh.request_edge_status();
  mesh.request_face_status();
  mesh.delete_isolated_vertices();
  mesh.garbage_collection();

  const auto core_start = Clock::now();
  OpenMesh::Decimater::DecimaterT<OmMesh> decimater(mesh);
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
  decimater.add(quadric);
  decimater.initialize();
  decimater.decimate_to(target_vertices);
  mesh.garbage_collection();
  PeerResult result;
  result.core_ms = ms_since(core_start);

  std::vector<float> positions;
  positions.reserve(3 * mesh.n_vertices());
  for (const auto& v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    positions.insert(positions.end(), {p[0], p[1], p[2]});
  }
  std::vector<uint32_t> indices;
  indices.reserve(3 * mesh.n_faces());
  for (const auto& f : mesh.faces())
    for (const auto& v : f.vertices()) indices.push_back(uint32_t(v.idx()));
  result.mesh = compact(positions, indices);
  result.mesh.origin = input.origin;  // positions stay in the input's frame
  result.mesh.scale = input.scale;
  result.ms = ms_since(start);
  if (refused)
    result.note = "refused " + std::to_string(refused) + " of " + std::to_string(input.face_count()) +
                  " faces (non-manifold or degenerate)";
  return result;
}

}  // namespace vpr::peers
