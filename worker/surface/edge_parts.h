// Connected parts of a mesh's edge graph (mesh_edges.h), found in parallel
// with the numbering of a serial walk: parts are numbered in order of their
// lowest vertex, and a vertex with no edge belongs to none. The surface CVT
// shares its target out by part; the serial walk it replaces was 15-19 ms of
// its host time on the H100 for igea's refined surface (docs/performance.md).
#pragma once

#include <cstdint>
#include <vector>

#include "surface/mesh_edges.h"

namespace vpr {

struct EdgeParts {
  std::vector<uint32_t> part;                   // per vertex; UINT32_MAX: no edge
  std::vector<std::vector<uint32_t>> elements;  // per part, its vertices ascending
};

EdgeParts edge_parts(const MeshEdges& edges);

}  // namespace vpr
