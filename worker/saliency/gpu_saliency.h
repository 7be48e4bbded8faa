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
#include "saliency/image_saliency.h"
#include "render/snapshot.h"
#include "core/status.h"
#include "render/views.h"

namespace vpr::cuda {

// One rendered view already in device memory (e.g. handed over by GL-CUDA
// interop): width x height, row-major, row 0 at the top, as in Snapshot. The
// pointers are not owned; whatever wrote them must be ordered before the call
// on ctx's stream (or finished).
struct DeviceSnapshot {
  int width = 0;
  int height = 0;
  const uint8_t* gray = nullptr;      // shaded intensity, background 0
  const uint8_t* coverage = nullptr;  // 1 where a surface was drawn
  const float* depth = nullptr;       // window-space depth in [0, 1]; 1 where no surface was drawn
};

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
