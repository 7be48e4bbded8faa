// Stage 3 (Section III-C): feature pixels back to 3D through the depth buffer.
#pragma once

#include <cstddef>  // image.h uses size_t without including it
#include <vector>

#include "core/exec_context.h"
#include "core/image.h"
#include "core/status.h"
#include "render/views.h"

namespace vpr {

// unproject_features' argument check, shared by both twins: features, depth and a sized view agree.
Status check_unproject_args(const Mask& features, const FloatImage& depth, const View& view);

}  // namespace vpr

namespace vpr::cpu {

// Appends one model-space point (3 floats) to *points for every pixel with
// features(x, y) != 0 and depth(x, y) < 1, in row-major pixel order. The pixel
// centre (x + 0.5, y + 0.5) is unprojected with view.inv_view_proj.
Status unproject_features(const Mask& features, const FloatImage& depth, const View& view, std::vector<float>* points,
                          const ExecContext& ctx);

}  // namespace vpr::cpu

// GPU twin, built when VPR_HAVE_CUDA (unproject.cu): same contract and order,
// on ctx's stream; returns once the points are on the host.
namespace vpr::cuda {
Status unproject_features(const Mask& features, const FloatImage& depth, const View& view, std::vector<float>* points,
                          const ExecContext& ctx);
}  // namespace vpr::cuda
