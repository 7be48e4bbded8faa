// Stage 4's visibility cue: the share of rendered views that see each vertex
// (visibility.h).
#include "saliency/visibility.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cassert>
#include <string>

namespace vpr {

Status check_visibility_args(const std::vector<View>& views, const std::vector<Snapshot>& snapshots,
                             const VisibilityOptions& options) {
  if (!(options.depth_tolerance >= 0.0f && options.depth_tolerance <= 1.0f))
    return invalid_argument("visibility: depth_tolerance = " + std::to_string(options.depth_tolerance) +
                            ", it must lie in [0, 1]");
  if (views.size() != snapshots.size())
    return invalid_argument("visibility: " + std::to_string(views.size()) + " views but " +
                            std::to_string(snapshots.size()) + " snapshots");
  for (size_t i = 0; i < views.size(); ++i) {
    const FloatImage& d = snapshots[i].depth;
    if (d.width <= 0 || d.height <= 0 || d.pixels.size() != size_t(d.width) * size_t(d.height) ||
        (views[i].width != 0 && (views[i].width != d.width || views[i].height != d.height)))
      return invalid_argument("visibility: view " + views[i].name + " is " + std::to_string(views[i].width) + "x" +
                              std::to_string(views[i].height) + " but its depth image is " + std::to_string(d.width) +
                              "x" + std::to_string(d.height));
  }
  return Status::Ok();
}

namespace cpu {

Status view_visibility(const float* vertices, size_t n, const std::vector<View>& views,
                       const std::vector<Snapshot>& snapshots, const VisibilityOptions& options,
                       std::vector<float>* visibility, const ExecContext&) {
  assert(visibility != nullptr);
  VPR_RETURN_IF_ERROR(check_visibility_args(views, snapshots, options));
  visibility->assign(n, 1.0f);
  if (views.empty()) return Status::Ok();
  float* out = visibility->data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 2048), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      int seen = 0;
      for (size_t i = 0; i < views.size(); ++i) {
        const FloatImage& d = snapshots[i].depth;
        seen += seen_by_view(views[i].view_proj.data(), d.pixels.data(), d.width, d.height, options.depth_tolerance,
                             vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]);
      }
      out[v] = float(seen) / float(views.size());
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
