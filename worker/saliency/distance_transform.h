// Distance transform (Eq. 4). The CPU twin is the exact linear-time Euclidean
// distance transform of Felzenszwalb and Huttenlocher (2012), rows and columns
// in parallel; the GPU twin may use another parallel exact method.
#pragma once

#include "core/exec_context.h"
#include "core/image.h"
#include "core/status.h"

namespace vpr {

// distance_transform's argument check, shared by both twins: a non-empty seed mask with width * height pixels.
Status check_distance_transform_args(const Mask& seeds);

}  // namespace vpr

namespace vpr::cpu {

// dist(x, y) = Euclidean distance in pixels from (x, y) to the nearest pixel with
// seeds != 0. With no seed at all, every pixel gets +infinity.
Status distance_transform(const Mask& seeds, FloatImage* dist, const ExecContext& ctx);

}  // namespace vpr::cpu

// GPU twin, built when VPR_HAVE_CUDA (distance_transform.cu): same contract
// and bit-identical distances, on ctx's stream; returns once the map is on the host.
namespace vpr::cuda {
Status distance_transform(const Mask& seeds, FloatImage* dist, const ExecContext& ctx);
}  // namespace vpr::cuda
