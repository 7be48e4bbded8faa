// Median pre-filter (Section III-A): removes shading noise before the
// inner-feature filter. Integer-exact, so the GPU twin (median_at and
// majority_at in image_kernels.h) gives identical pixels.
#pragma once

#include "core/exec_context.h"
#include "core/image.h"
#include "core/status.h"

namespace vpr {

// Argument check of median_filter and majority_filter (what: the caller's name), shared by both twins.
Status check_median_filter_args(const char* what, const Image<uint8_t>& in, int size);

}  // namespace vpr

namespace vpr::cpu {

// size x size window (odd); pixels outside the image are clamped to the edge.
Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& ctx);

// The same filter on a mask (any nonzero pixel counts as 1): out(x, y) = 1 where
// more than half of the size x size window (edges clamped) is set, which is the
// median of the 0/1 image, computed from box counts in O(1) per pixel.
Status majority_filter(const Mask& in, int size, Mask* out, const ExecContext& ctx);

}  // namespace vpr::cpu

// GPU twins, built when VPR_HAVE_CUDA (median_filter.cu): same contracts, on
// ctx's stream; they return once the result is on the host.
namespace vpr::cuda {
Status median_filter(const GrayImage& in, int size, GrayImage* out, const ExecContext& ctx);
Status majority_filter(const Mask& in, int size, Mask* out, const ExecContext& ctx);
}  // namespace vpr::cuda
