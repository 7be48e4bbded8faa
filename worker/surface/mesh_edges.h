// A triangle mesh's edges in compressed rows: per vertex its neighbours,
// sorted, each with how many faces use the edge (1: a boundary edge). The
// surface back half walks these rows in every stage (refinement, smoothing of
// the density, the CVT's sweeps), so they are built once per mesh, in
// parallel, with a result that does not depend on the thread count.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/exec_context.h"
#include "core/mesh.h"
#include "core/status.h"

namespace vpr {

struct MeshEdges {
  std::vector<uint32_t> offset;    // vertex_count + 1
  std::vector<uint32_t> neighbor;  // row v: offset[v] .. offset[v + 1], ascending
  std::vector<uint32_t> faces;     // per entry: faces that use the edge
  size_t vertex_count() const { return offset.empty() ? 0 : offset.size() - 1; }
  size_t degree(uint32_t v) const { return offset[v + 1] - offset[v]; }
  const uint32_t* begin(uint32_t v) const { return neighbor.data() + offset[v]; }
  const uint32_t* end(uint32_t v) const { return neighbor.data() + offset[v + 1]; }
  // The entry of b in a's row (UINT32_MAX when not adjacent): entry(min, max)
  // numbers each undirected edge once.
  uint32_t entry(uint32_t a, uint32_t b) const {
    const uint32_t* it = std::lower_bound(begin(a), end(a), b);
    return it != end(a) && *it == b ? uint32_t(it - neighbor.data()) : UINT32_MAX;
  }
};

// Each vertex's corners (corner 3 f + k: face f's k-th index), ascending, so
// a row lists the vertex's faces in face order.
struct VertexCorners {
  std::vector<uint32_t> offset;  // vertex_count + 1, or empty: not built
  std::vector<uint32_t> corner;  // row v: offset[v] .. offset[v + 1]
  bool built(size_t vertex_count) const { return offset.size() == vertex_count + 1; }
};

// The corners by vertex of an index buffer over vertex_count vertices: on 8
// threads or more in parallel (atomic slots, then each row sorted), else a
// counting sort; the same rows.
VertexCorners vertex_corners(const std::vector<uint32_t>& indices, size_t vertex_count);

// A face's corner repeated (a == b) gives no edge.
MeshEdges mesh_edges(const Mesh& mesh);
// The same from an index buffer (three per face) over vertex_count vertices.
// corners, when given, gets the corners by vertex where the rows were made
// from them (on 8 threads or more, mesh_edges.cpp), else is left empty.
MeshEdges mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count, VertexCorners* corners = nullptr);

// A twin that makes the rows and the corners by vertex elsewhere (the GPU's,
// below); on an error the caller makes them here.
using MeshEdgesTwin =
    std::function<Status(const std::vector<uint32_t>& indices, size_t vertex_count, MeshEdges*, VertexCorners*)>;

// The GPU twin, built when VPR_HAVE_CUDA (mesh_edges.cu): the same rows as
// mesh_edges (integers only), and the corners by vertex always.
namespace cuda {
Status mesh_edges(const std::vector<uint32_t>& indices, size_t vertex_count, MeshEdges* edges, VertexCorners* corners,
                  const ExecContext& ctx);
}  // namespace cuda

}  // namespace vpr
