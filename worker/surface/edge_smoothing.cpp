#include "surface/edge_smoothing.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

namespace vpr::cpu {

Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<Vec3d>* values) {
  const size_t nv = edges.vertex_count();
  if (values->size() != nv)
    return invalid_argument("edge smoothing: " + std::to_string(values->size()) + " values for " + std::to_string(nv) +
                            " vertices");
  std::vector<Vec3d>& now = *values;
  std::vector<Vec3d> next(nv);
  for (int pass = 0; pass < passes; ++pass) {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 4096), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t v = r.begin(); v != r.end(); ++v)
        next[v] = smoothed_vector(edges.offset.data(), edges.neighbor.data(), now.data(), v);
    });
    now.swap(next);
  }
  return Status::Ok();
}

}  // namespace vpr::cpu
