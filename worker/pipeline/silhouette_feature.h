// Silhouette-feature filter (Section III-B, Eq. 4-5): finds the parts of the
// silhouette that belong to thin features (legs, ears, tails).
#pragma once

#include "exec_context.h"
#include "image.h"
#include "status.h"

namespace vpr::cpu {

// Foreground pixels with at least one background 4-neighbour (or on the image border).
Status silhouette_pixels(const Mask& foreground, Mask* silhouette, const ExecContext& ctx);

// Eq. (5): four directional kernels (0, 45, 90, 135 degrees) over the distance
// map; lambda sets the kernel reach. A foreground pixel is on the skeleton when
// it is a ridge of the distance map across one of the four directions.
Status skeleton(const FloatImage& silhouette_distance, const Mask& foreground, int lambda, Mask* skeleton,
                const ExecContext& ctx);

// Silhouette pixels whose feature size (distance to the nearest skeleton pixel)
// is below threshold_px.
Status thin_features(const Mask& silhouette, const Mask& skeleton, float threshold_px, Mask* thin,
                     const ExecContext& ctx);

}  // namespace vpr::cpu
