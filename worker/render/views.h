// Stage 1 (Section III): the cameras. Six orthogonal views of the model's
// bounding box (or fourteen: six axes plus eight diagonals), orthographic, so
// that depth is linear and unprojection (stage 3) is one matrix product.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/status.h"
#include "core/vec3.h"

namespace vpr {

struct ViewOptions {
  int count = 6;         // 6 (axes) or 14 (axes + 8 diagonals)
  int resolution = 512;  // square images, resolution x resolution pixels, in [16, 8192]
  float margin = 0.05f;  // empty border around the model, as a fraction of the image, in [0, 0.45)
  // Orientation: the paper uses the model's own axes; we align to the principal
  // axes (PCA, area-weighted) by default, which the paper left as future work.
  bool pca_align = true;
  // Optional user rotation (row-major 3x3, model -> aligned, orthonormal with
  // det +1 within 1e-6), applied instead of PCA when set.
  std::optional<std::array<double, 9>> user_rotation;
};

// Column-major 4x4 matrices (OpenGL convention).
using Mat4 = std::array<double, 16>;

struct View {
  std::string name;  // side of the aligned model the camera is on: "+x", "-x", ..., "+x+y+z"
  int width = 0;
  int height = 0;
  Mat4 view_proj{};      // model space -> clip space (includes the alignment rotation)
  Mat4 inv_view_proj{};  // clip space -> model space
  Vec3 toward_camera;    // unit vector in model space pointing from the model to the camera
};

// Rotation (row-major 3x3) taking model space to the aligned frame.
std::array<double, 9> alignment_rotation(const Mesh& mesh, const ViewOptions& options);

// Views in the order +x, -x, +y, -y, +z, -z, then +x+y+z, +x+y-z, +x-y+z,
// +x-y-z, -x+y+z, -x+y-z, -x-y+z, -x-y-z. Image up is the aligned +z (+y for
// the +-z views). Each frustum is the tight square around the projected
// vertices, widened so `margin` of the image stays empty on each side; depth
// spans the model plus 1% of the box diagonal either way.
// kInvalidArgument for a bad option, an empty or non-finite mesh, a box that is
// a single point, or a user rotation that is not orthonormal with det +1.
StatusOr<std::vector<View>> make_views(const Mesh& mesh, const ViewOptions& options);

// Helpers shared with unprojection and tests.
Vec3d transform_point(const Mat4& m, Vec3d p);  // with perspective divide
Mat4 invert(const Mat4& m);

}  // namespace vpr
