// Inner-feature filter (Section III-A, Eq. 1-3): a pixel is a feature when it is
// darker than its Gaussian-weighted neighbourhood by more than C.
// Integer arithmetic (fixed-point weights) so the GPU twin gives identical pixels.
#pragma once

#include <vector>

#include "core/exec_context.h"
#include "core/image.h"
#include "core/status.h"

namespace vpr {

// n x n Gaussian weights (Eq. 1), quantized to integers summing to 2^16.
std::vector<int> gaussian_weights_fixed(int n, float sigma);

// inner_features' argument check, shared by both twins so they fail alike.
Status check_inner_features_args(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c);

namespace cpu {

// features(x, y) = 1 where foreground(x, y) and T(x, y) > P(x, y) (Eq. 3), with
// P the filtered gray value and T the weighted mean (Eq. 2) minus C.
Status inner_features(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c, Mask* features,
                      const ExecContext& ctx);

}  // namespace cpu

// GPU twin, built when VPR_HAVE_CUDA (inner_feature.cu): same contract, on
// ctx's stream; returns once the result is on the host.
namespace cuda {
Status inner_features(const GrayImage& filtered, const Mask& foreground, int n, float sigma, int c, Mask* features,
                      const ExecContext& ctx);
}  // namespace cuda
}  // namespace vpr
