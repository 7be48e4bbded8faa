#include "debug_output.h"

#include <vector>

#include "io/mesh_io.h"
#include "io/png_io.h"

namespace vpr {
namespace {

// "+x" -> "px", "-x+y-z" -> "mxpymz": file names without shell-special signs.
std::string file_safe(const std::string& view_name) {
  std::string out;
  for (char c : view_name) out += c == '+' ? 'p' : c == '-' ? 'm' : c;
  return out;
}

}  // namespace

Status write_feature_overlay(const std::string& path, const Snapshot& snapshot, const FeatureImages& f) {
  const int w = snapshot.gray.width, h = snapshot.gray.height;
  std::vector<uint8_t> rgb(size_t(w) * h * 3);
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    uint8_t c[3] = {snapshot.gray.pixels[i], snapshot.gray.pixels[i], snapshot.gray.pixels[i]};
    if (f.inner.pixels[i]) c[0] = 230, c[1] = 40, c[2] = 40;
    if (f.thin.pixels[i]) c[0] = 250, c[1] = 210, c[2] = 30;
    if (f.skeleton.pixels[i]) c[0] = 40, c[1] = 200, c[2] = 230;
    for (int k = 0; k < 3; ++k) rgb[3 * i + k] = c[k];
  }
  return write_rgb_png(path, w, h, rgb.data());
}

Status write_view_debug(const std::string& dir, const View& view, const Snapshot& snapshot, const FeatureImages& f,
                        const std::vector<float>& view_points) {
  const std::string base = dir + "/view_" + file_safe(view.name);
  VPR_RETURN_IF_ERROR(write_png(base + "_snapshot.png", snapshot.gray));
  VPR_RETURN_IF_ERROR(write_png(base + "_filtered.png", f.filtered));
  VPR_RETURN_IF_ERROR(write_mask_png(base + "_inner.png", f.inner));
  VPR_RETURN_IF_ERROR(write_mask_png(base + "_silhouette.png", f.thin));
  VPR_RETURN_IF_ERROR(write_mask_png(base + "_skeleton.png", f.skeleton));
  VPR_RETURN_IF_ERROR(write_feature_overlay(base + "_overlay.png", snapshot, f));
  return write_point_ply(base + "_points.ply", view_points.data(), view_points.size() / 3, nullptr);
}

}  // namespace vpr
