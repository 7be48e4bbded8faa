// Stage 3 (Section III-C): feature pixels back to 3D. The views are
// orthographic, so a pixel and its depth give the surface point by one matrix
// product with the inverse view-projection; no ray casting is needed.
#include "saliency/unproject.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

#include "core/vec3.h"

namespace vpr {

Status check_unproject_args(const Mask& features, const FloatImage& depth, const View& view) {
  const int w = depth.width, h = depth.height;
  if (features.width != w || features.height != h)
    return invalid_argument("feature mask is " + std::to_string(features.width) + "x" +
                            std::to_string(features.height) + " but the depth image is " + std::to_string(w) + "x" +
                            std::to_string(h));
  if (view.width != 0 && (view.width != w || view.height != h))
    return invalid_argument("view " + view.name + " is " + std::to_string(view.width) + "x" +
                            std::to_string(view.height) + " but the depth image is " + std::to_string(w) + "x" +
                            std::to_string(h));
  return Status::Ok();
}

namespace cpu {

Status unproject_features(const Mask& features, const FloatImage& depth, const View& view, std::vector<float>* points,
                          const ExecContext& /*ctx*/) {
  assert(points != nullptr);
  VPR_RETURN_IF_ERROR(check_unproject_args(features, depth, view));
  const int w = depth.width, h = depth.height;
  if (w <= 0 || h <= 0) return Status::Ok();

  // One buffer per row, concatenated in row order afterwards, so the output is
  // the same for any thread count.
  std::vector<std::vector<float>> rows(static_cast<size_t>(h));
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& r) {
    for (int y = r.begin(); y != r.end(); ++y) {
      std::vector<float>& out = rows[size_t(y)];
      // Row 0 is the top of the image; GL window coordinates count from the bottom.
      const double ndc_y = 2.0 * (double(h - y) - 0.5) / h - 1.0;
      for (int x = 0; x < w; ++x) {
        const float z = depth.at(x, y);
        if (!features.at(x, y) || !(z < 1.0f)) continue;
        const double ndc_x = 2.0 * (x + 0.5) / w - 1.0;
        const Vec3d p = transform_point(view.inv_view_proj, {ndc_x, ndc_y, 2.0 * double(z) - 1.0});
        out.push_back(float(p.x));
        out.push_back(float(p.y));
        out.push_back(float(p.z));
      }
    }
  });

  size_t total = points->size();
  for (const auto& r : rows) total += r.size();
  points->reserve(total);
  for (const auto& r : rows) points->insert(points->end(), r.begin(), r.end());
  return Status::Ok();
}

}  // namespace cpu
}  // namespace vpr
