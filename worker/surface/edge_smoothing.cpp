#include "surface/edge_smoothing.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

namespace vpr::cpu {

namespace {

template <class T, class Pass>
Status smooth(const MeshEdges& edges, int passes, std::vector<T>* values, Pass pass) {
  const size_t nv = edges.vertex_count();
  if (values->size() != nv)
    return invalid_argument("edge smoothing: " + std::to_string(values->size()) + " values for " + std::to_string(nv) +
                            " vertices");
  std::vector<T>& now = *values;
  std::vector<T> next(nv);
  for (int p = 0; p < passes; ++p) {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 4096), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t v = r.begin(); v != r.end(); ++v)
        next[v] = pass(edges.offset.data(), edges.neighbor.data(), now.data(), v);
    });
    now.swap(next);
  }
  return Status::Ok();
}

}  // namespace

Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<Vec3d>* values) {
  return smooth(edges, passes, values, smoothed_vector);
}

Status smooth_over_edges(const MeshEdges& edges, int passes, std::vector<float>* values) {
  return smooth(edges, passes, values, smoothed_scalar);
}

}  // namespace vpr::cpu
