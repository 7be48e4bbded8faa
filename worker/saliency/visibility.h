// Stage 4's visibility cue (our addition, for the attention field): the share
// of the rendered views that see each vertex, the views optionally weighted
// towards the front and top. A person looks at what faces
// them from many sides; recesses, and the far side of thin parts, are seen
// from few. Measured on ../shared/gaze/ (docs/perception.md), the attention
// field gains most from this cue, and more with 14 views than with 6.
//
// A vertex is seen by a view when its window depth is at most the farthest
// depth in the 3 x 3 pixels around its projection plus `depth_tolerance`
// (the farthest, so that vertices on a silhouette or a steep slope, whose own
// pixel may show the surface in front of them, count as seen). Orthographic
// views (views.h): window depth is linear in model space.
#pragma once

#include <cstddef>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "render/snapshot.h"
#include "render/views.h"

namespace vpr {

struct VisibilityOptions {
  // Window-depth units (each view's depth range spans the model along the
  // view plus 2% of the diagonal): 0.01 is about 1% of the model's depth.
  float depth_tolerance = 0.01f;
  // Views weighted by how a person looks at an object (Lavoue et al. 2018:
  // from the front and above): view i weighs 1 - b + b (1 + cos t_i) / 2, t_i
  // the angle between its direction towards the camera and view_direction
  // (model frame: +y up, +z front), b = view_bias in [0, 1]. 0: every view
  // counts alike (the plain share of views).
  float view_bias = 0.0f;
  Vec3 view_direction = {0.0f, 1.0f, 1.0f};
};

// The views' weights (VisibilityOptions::view_bias), shared by both twins.
std::vector<double> view_weights(const std::vector<View>& views, const VisibilityOptions& options);

// The options alone: tolerance and bias in [0, 1], a direction when biased.
Status check_visibility_options(const VisibilityOptions& options);
// views and snapshots: one snapshot per view, each snapshot's depth the view's
// size. INVALID_ARGUMENT otherwise, or for a tolerance outside [0, 1].
Status check_visibility_args(const std::vector<View>& views, const std::vector<Snapshot>& snapshots,
                             const VisibilityOptions& options);

// Shared by both twins: the view-projection as floats-in-doubles, applied as
// transform_point does, then the 3 x 3 depth test. depth: width x height,
// row 0 at the top.
VPR_HD inline bool seen_by_view(const double* view_proj, const float* depth, int width, int height, float tolerance,
                                double px, double py, double pz) {
  const double* m = view_proj;
  const double w = m[3] * px + m[7] * py + m[11] * pz + m[15];
  const double nx = (m[0] * px + m[4] * py + m[8] * pz + m[12]) / w;
  const double ny = (m[1] * px + m[5] * py + m[9] * pz + m[13]) / w;
  const double nz = (m[2] * px + m[6] * py + m[10] * pz + m[14]) / w;
  const double fx = (nx + 1.0) * 0.5 * width, fy = (1.0 - ny) * 0.5 * height;  // row 0 at the top
  if (!(fx >= 0.0 && fy >= 0.0 && fx < double(width) && fy < double(height))) return false;
  const int x = int(fx), y = int(fy);
  float farthest = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
      const float d = depth[size_t(yy) * size_t(width) + size_t(xx)];
      farthest = d > farthest ? d : farthest;
    }
  return float(0.5 * (nz + 1.0)) <= farthest + tolerance;
}

namespace cpu {

// vertices: #V x 3 floats, model space (the space the views were made in).
// visibility: #V values in [0, 1], the (weighted) share of views that see
// each vertex; no views: all 1.
Status view_visibility(const float* vertices, size_t vertex_count, const std::vector<View>& views,
                       const std::vector<Snapshot>& snapshots, const VisibilityOptions& options,
                       std::vector<float>* visibility, const ExecContext& ctx);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (visibility.cu): the same contract and
// the same values (the same double arithmetic, no FMA contraction).
namespace cuda {

Status view_visibility(const float* vertices, size_t vertex_count, const std::vector<View>& views,
                       const std::vector<Snapshot>& snapshots, const VisibilityOptions& options,
                       std::vector<float>* visibility, const ExecContext& ctx);
// The same from depth images already on the device (device_snapshots.h:
// DeviceSnapshots::depths): views.size() images back to back on ctx's
// stream, each views[0].width x views[0].height, every view that size.
Status view_visibility_on_device(const float* vertices, size_t vertex_count, const std::vector<View>& views,
                                 const float* device_depths, const VisibilityOptions& options,
                                 std::vector<float>* visibility, const ExecContext& ctx);

}  // namespace cuda
}  // namespace vpr
