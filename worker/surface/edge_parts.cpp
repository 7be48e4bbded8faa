#include "surface/edge_parts.h"

#include <tbb/parallel_for.h>

#include "core/concurrent_parents.h"

namespace vpr {
EdgeParts edge_parts(const MeshEdges& edges) {
  const size_t nv = edges.vertex_count();
  ConcurrentParents parents(nv);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v)
      for (const uint32_t* w = edges.begin(v); w != edges.end(v); ++w)
        if (*w > v) parents.unite(v, *w);  // each edge once
  });
  std::vector<uint32_t> root(nv);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 16384), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v) root[v] = parents.find(v);
  });
  // Numbered by lowest vertex (each root is its part's lowest vertex, so it
  // comes before the part's other vertices), as a walk from each vertex not
  // yet reached, in index order, numbers them.
  EdgeParts out;
  out.part.assign(nv, UINT32_MAX);
  for (uint32_t v = 0; v < nv; ++v) {
    if (edges.degree(v) == 0) continue;
    if (root[v] == v) {
      out.part[v] = uint32_t(out.elements.size());
      out.elements.emplace_back();
    } else {
      out.part[v] = out.part[root[v]];
    }
    out.elements[out.part[v]].push_back(v);
  }
  return out;
}

}  // namespace vpr
