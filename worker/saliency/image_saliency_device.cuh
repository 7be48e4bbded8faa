// Device-pointer entry points of the stage 2-3 GPU twins (Section III), shared
// by their .cu files: the host-signature twins (vpr::cuda::median_filter, ...)
// upload, call these and download; the fused per-view path (gpu_saliency.h)
// chains them without leaving the device. Every image is row-major, w x h,
// row 0 at the top, in device memory; every launch is on ctx's stream and
// checked. Nothing here synchronizes.
#pragma once

#include <cuda_runtime.h>

#include <cstdint>
#include <string>
#include <vector>

#include "gpu/device_buffer.h"
#include "saliency/image_saliency.h"
#include "render/views.h"

namespace vpr::cuda::detail {

// The twins refuse a context without a stream rather than fall back to the
// legacy default stream, which would serialize every job on the device.
inline Status require_stream(const ExecContext& ctx, const char* what) {
  if (ctx.stream == nullptr) return internal_error(std::string(what) + ": ExecContext has no CUDA stream");
  return Status::Ok();
}

// 2D launch shape: 32 x 8 threads, one per pixel.
inline dim3 pixel_block() {
  return dim3(32, 8);
}
inline dim3 pixel_grid(int w, int h) {
  return dim3(unsigned((w + 31) / 32), unsigned((h + 7) / 8));
}

// Section III-A: size x size median of gray, and majority vote of a mask (any
// nonzero is 1); edges clamped.
Status launch_median(const uint8_t* gray, int w, int h, int size, uint8_t* out, const ExecContext& ctx);
Status launch_majority(const uint8_t* mask, int w, int h, int size, uint8_t* out, const ExecContext& ctx);

// Eq. (1)-(3). weights: n x n device ints summing to 2^16. exclude (nullable):
// pixels set there are never features (detect_features passes the silhouette).
Status launch_inner_features(const uint8_t* filtered, const uint8_t* foreground, const uint8_t* exclude, int w, int h,
                             const int* weights, int n, int c, uint8_t* features, const ExecContext& ctx);

// Eq. (4), exact: dist = Euclidean distance to the nearest seed, +inf with no
// seed. needed (nullable): pixels not set there get 0 and cost nothing.
Status distance_transform_device(const uint8_t* seeds, int w, int h, const uint8_t* needed, float* dist,
                                 const ExecContext& ctx);

// Silhouette pixels of a foreground mask (silhouette_at).
Status launch_silhouette(const uint8_t* foreground, int w, int h, uint8_t* out, const ExecContext& ctx);

// Eq. (5). masked: the distance map, 0 off the foreground.
Status launch_skeleton(const float* masked, int w, int h, int m, uint8_t* out, const ExecContext& ctx);

// Thin silhouette features (see cpu::thin_features). features_out (nullable)
// also receives inner | thin, with inner (then non-null) the inner features.
Status thin_features_device(const uint8_t* foreground, const uint8_t* silhouette, const uint8_t* skeleton,
                            const float* silhouette_distance, int w, int h, float threshold_px, uint8_t* thin,
                            const uint8_t* inner, uint8_t* features_out, const ExecContext& ctx);

// Stage 3: appends the model-space points of the feature pixels with depth < 1,
// row-major. Synchronizes the stream (the host needs the count).
Status unproject_device(const uint8_t* features, const float* depth, int w, int h, const View& view,
                        std::vector<float>* points, const ExecContext& ctx);

// All of stage 2 on device images; out's buffers are (re)allocated w x h.
struct DeviceFeatures {
  DeviceBuffer<uint8_t> filtered, foreground, silhouette, inner, skeleton, thin, features;
  DeviceBuffer<float> silhouette_distance;
};
Status detect_features_device(const uint8_t* gray, const uint8_t* coverage, int w, int h,
                              const ImageSaliencyOptions& options, DeviceFeatures* out, const ExecContext& ctx);
// Queues the download of every image of `in` into *out (resized here);
// synchronize the stream before reading them.
Status download_features(const DeviceFeatures& in, int w, int h, FeatureImages* out);

}  // namespace vpr::cuda::detail
