// Silhouette-feature filter (Section III-B, Eq. 4-5): finds the parts of the
// silhouette that belong to thin features (legs, ears, tails).
#pragma once

#include "core/exec_context.h"
#include "core/image.h"
#include "core/status.h"

namespace vpr {

// Argument checks shared by the CPU and GPU twins, so both fail alike.
// silhouette_pixels: a non-empty foreground with width * height pixels.
Status check_silhouette_pixels_args(const Mask& foreground);
// skeleton: a non-empty distance map, a foreground of its size, lambda even in [2, 64].
Status check_skeleton_args(const FloatImage& silhouette_distance, const Mask& foreground, int lambda);
// thin_features: four non-empty images of one size, threshold_px finite and >= 0.
Status check_thin_features_args(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                                const FloatImage& silhouette_distance, float threshold_px);

}  // namespace vpr

namespace vpr::cpu {

// Foreground pixels with at least one background 4-neighbour (or on the image border).
Status silhouette_pixels(const Mask& foreground, Mask* silhouette, const ExecContext& ctx);

// Eq. (5): four directional kernels (0, 45, 90, 135 degrees) over the distance
// map; lambda (even, >= 2) sets the kernel reach, lambda / 2 pixels each way. A
// foreground pixel is on the skeleton when its distance is >= 2 and it is a
// ridge of the distance map across one of the four directions (response >= 0.5
// of an ideal ridge; see skeleton_response_at in image_kernels.h).
// silhouette_distance: Eq. (4), the distance transform seeded by the silhouette.
Status skeleton(const FloatImage& silhouette_distance, const Mask& foreground, int lambda, Mask* skeleton,
                const ExecContext& ctx);

// Silhouette pixels whose feature size is below threshold_px (pixels). The
// feature size is the distance to the nearest skeleton pixel, with two cases
// the skeleton cannot see:
//  - parts thinner than about 5 px have no pixel with distance >= 2, hence no
//    skeleton: their silhouette pixels, farther than 3 px from any foreground
//    pixel with distance >= 2, are thin (when threshold_px > 2);
//  - with no skeleton pixel at all, every silhouette pixel is thin when the
//    largest distance over the foreground is below threshold_px.
Status thin_features(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                     const FloatImage& silhouette_distance, float threshold_px, Mask* thin, const ExecContext& ctx);

}  // namespace vpr::cpu

// GPU twins, built when VPR_HAVE_CUDA (silhouette_feature.cu): same contracts,
// on ctx's stream; they return once the result is on the host.
namespace vpr::cuda {
Status silhouette_pixels(const Mask& foreground, Mask* silhouette, const ExecContext& ctx);
Status skeleton(const FloatImage& silhouette_distance, const Mask& foreground, int lambda, Mask* skeleton,
                const ExecContext& ctx);
Status thin_features(const Mask& foreground, const Mask& silhouette, const Mask& skeleton,
                     const FloatImage& silhouette_distance, float threshold_px, Mask* thin, const ExecContext& ctx);
}  // namespace vpr::cuda
