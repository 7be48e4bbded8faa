// A GPU job's snapshots kept on the device (the GL-CUDA interop): the
// renderer reads every view's colour and depth into two pixel-pack buffers on
// the GPU (render(), SnapshotSink), CUDA maps those buffers once and a kernel
// a view turns them into the snapshot's gray, coverage and depth images
// (gl_pixels.h's rule, the host read-back's bits). Stages 2-3 and the
// visibility cue then start from device memory: no glReadPixels to the host,
// no host conversion, no upload. Built when VPR_HAVE_CUDA.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/exec_context.h"
#include "core/status.h"
#include "render/snapshot.h"

namespace vpr::cuda {

// One rendered view in device memory: width x height, row-major, row 0 at
// the top, as in Snapshot. The pointers are not owned; whatever wrote them
// must be ordered before their use on the reader's stream (or finished).
struct DeviceSnapshot {
  int width = 0;
  int height = 0;
  const uint8_t* gray = nullptr;      // shaded intensity, background 0
  const uint8_t* coverage = nullptr;  // 1 where a surface was drawn
  const float* depth = nullptr;       // window-space depth in [0, 1]; 1 where no surface was drawn
};

// The sink a GPU job hands Renderer::render. The images live on ctx's stream
// and are charged to its budget; the object must outlive their readers' work.
class DeviceSnapshots final : public SnapshotSink {
 public:
  // views: the views about to be rendered (their sizes set the storage).
  DeviceSnapshots(const std::vector<View>& views, const ExecContext& ctx);
  ~DeviceSnapshots() override;
  DeviceSnapshots(const DeviceSnapshots&) = delete;
  DeviceSnapshots& operator=(const DeviceSnapshots&) = delete;

  // The images' device memory (take() makes it otherwise): RESOURCE_EXHAUSTED
  // past the job's budget, before anything is rendered.
  Status allocate();
  // INVALID_ARGUMENT for views other than those given; UNAVAILABLE when CUDA
  // cannot map the context's buffers here (the GL
  // context is on another GPU than the job's, or the driver refuses), named;
  // RESOURCE_EXHAUSTED past the job's device budget.
  Status take(const PixelBuffers& pixels) override;

  // The views' count once a render handed them over, else 0.
  size_t size() const;
  DeviceSnapshot snapshot(size_t view) const;
  // Every view's depth back to back (the visibility cue's input), each
  // width x height of view 0's size; null unless the views share one size.
  const float* depths() const;
  // The images copied to the host, as the renderer's read-back gives them
  // (for the CPU twins when a GPU twin fails, and debug output).
  Status download(std::vector<Snapshot>* out) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vpr::cuda
