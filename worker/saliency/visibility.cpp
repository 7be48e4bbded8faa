// Stage 4's visibility cue: the share of rendered views that see each vertex
// (visibility.h).
#include "saliency/visibility.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cassert>
#include <cmath>
#include <string>

namespace vpr {

Status check_visibility_options(const VisibilityOptions& options) {
  if (!(options.depth_tolerance >= 0.0f && options.depth_tolerance <= 1.0f))
    return invalid_argument("visibility: depth_tolerance = " + std::to_string(options.depth_tolerance) +
                            ", it must lie in [0, 1]");
  if (!(options.view_bias >= 0.0f && options.view_bias <= 1.0f))
    return invalid_argument("visibility: view_bias = " + std::to_string(options.view_bias) + ", it must lie in [0, 1]");
  if (options.view_bias > 0.0f && !(dot(options.view_direction, options.view_direction) > 0.0f))
    return invalid_argument("visibility: view_direction is zero or not finite");
  return Status::Ok();
}

Status check_visibility_args(const std::vector<View>& views, const std::vector<Snapshot>& snapshots,
                             const VisibilityOptions& options) {
  VPR_RETURN_IF_ERROR(check_visibility_options(options));
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

std::vector<double> view_weights(const std::vector<View>& views, const VisibilityOptions& o) {
  std::vector<double> w(views.size(), 1.0);
  if (o.view_bias <= 0.0f) return w;
  const Vec3d d{o.view_direction.x, o.view_direction.y, o.view_direction.z};
  const double len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  for (size_t i = 0; i < views.size(); ++i) {
    const Vec3& t = views[i].toward_camera;  // unit, model frame
    const double c = (d.x * t.x + d.y * t.y + d.z * t.z) / len;
    w[i] = 1.0 - o.view_bias + o.view_bias * 0.5 * (1.0 + c);
  }
  return w;
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
  const std::vector<double> weight = view_weights(views, options);
  double total = 0;
  for (double w : weight) total += w;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 2048), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      double seen = 0;
      for (size_t i = 0; i < views.size(); ++i) {
        const FloatImage& d = snapshots[i].depth;
        if (seen_by_view(views[i].view_proj.data(), d.pixels.data(), d.width, d.height, options.depth_tolerance,
                         vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]))
          seen += weight[i];
      }
      out[v] = float(seen / total);
    }
  });
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
