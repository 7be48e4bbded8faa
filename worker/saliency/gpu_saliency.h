// Stages 2-3 (Section III) of one view on the GPU, fused: the snapshot goes
// through the image-space saliency filters (Eq. 1-5) and the unprojection
// without leaving the device, and only the saliency points come back (plus the
// feature images when asked, for --debug-dir). Built when VPR_HAVE_CUDA.
// Equal to cpu::detect_features followed by cpu::unproject_features(features,
// depth, ...): identical masks and the points in the same row-major order.
#pragma once

#include <cstdint>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "render/device_snapshots.h"
#include "render/snapshot.h"
#include "render/views.h"
#include "saliency/image_saliency.h"

namespace vpr::cuda {

// Appends 3 floats (model space) per saliency point of the view to *points.
// debug: null downloads nothing but the points; otherwise it receives every
// feature image, as cpu::detect_features fills them. Synchronizes ctx's stream
// before returning. INVALID_ARGUMENT for images of different sizes or a bad
// option, RESOURCE_EXHAUSTED when the job's device budget or the device runs
// out (rerun on the CPU), INTERNAL for other CUDA errors.
Status view_saliency_points(const Snapshot& snapshot, const View& view, const ImageSaliencyOptions& options,
                            std::vector<float>* points, FeatureImages* debug, const ExecContext& ctx);
Status view_saliency_points(const DeviceSnapshot& snapshot, const View& view, const ImageSaliencyOptions& options,
                            std::vector<float>* points, FeatureImages* debug, const ExecContext& ctx);

}  // namespace vpr::cuda
