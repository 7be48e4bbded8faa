// The GL-CUDA hand-over of a GPU job's snapshots (device_snapshots.h). Once a
// render: register the renderer's two pixel-pack buffers (every view's pixels
// back to back), map them on the job's stream, one kernel a view writes the
// snapshot's images (gl_pixels.h, the host read-back's rule), unmap and
// unregister. Mapping orders GL's copies into the buffers before the kernels.
// One map a render, not one a view (docs/performance.md, issue 15, session 23).
#include <cuda_gl_interop.h>

#include <algorithm>
#include <string>

#include "gpu/cuda_check.h"
#include "gpu/device_buffer.h"
#include "render/device_snapshots.h"
#include "render/gl_pixels.h"

namespace vpr::cuda {
namespace {

__global__ void snapshot_kernel(const uint8_t* rgba, const float* depth, int width, int height, uint8_t* gray_out,
                                float* depth_out, uint8_t* coverage_out) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= width || y >= height) return;
  gl::snapshot_pixel(rgba, depth, width, height, x, y, gray_out, depth_out, coverage_out);
}

// An interop call's failure: UNAVAILABLE, so that the job reads back instead.
Status interop_failed(cudaError_t err, const std::string& what) {
  cudaGetLastError();
  return unavailable("GL-CUDA interop: " + what + " failed: " + cudaGetErrorName(err) + " (" + cudaGetErrorString(err) +
                     ")");
}

}  // namespace

struct DeviceSnapshots::Impl {
  ExecContext ctx;
  std::vector<int> width, height;
  std::vector<size_t> offset;  // each view's first pixel in the arrays below
  size_t pixels = 0;
  bool same_size = true;
  DeviceBuffer<uint8_t> gray, coverage;
  DeviceBuffer<float> depth;
  bool taken = false;

  // The GL context must be on the job's GPU: CUDA maps only its own
  // device's buffers without a copy through the host.
  Status check_device() {
    int job_device = 0;
    VPR_CUDA_TRY(cudaGetDevice(&job_device));
    unsigned count = 0;
    int devices[16];
    const cudaError_t err = cudaGLGetDevices(&count, devices, 16, cudaGLDeviceListAll);
    if (err != cudaSuccess) return interop_failed(err, "cudaGLGetDevices");
    std::string listed;
    for (unsigned i = 0; i < count; ++i) {
      if (devices[i] == job_device) return Status::Ok();
      listed += (listed.empty() ? "" : ", ") + std::to_string(devices[i]);
    }
    return unavailable("GL-CUDA interop: the GL context renders on CUDA device " +
                       (listed.empty() ? std::string("none") : listed) + ", the job runs on device " +
                       std::to_string(job_device));
  }
};

DeviceSnapshots::DeviceSnapshots(const std::vector<View>& views, const ExecContext& ctx)
    : impl_(std::make_unique<Impl>()) {
  impl_->ctx = ctx;
  for (const View& v : views) {
    impl_->width.push_back(v.width);
    impl_->height.push_back(v.height);
    impl_->offset.push_back(impl_->pixels);
    impl_->pixels += size_t(std::max(v.width, 0)) * size_t(std::max(v.height, 0));
    impl_->same_size &= v.width == views[0].width && v.height == views[0].height;
  }
}

DeviceSnapshots::~DeviceSnapshots() = default;

Status DeviceSnapshots::allocate() {
  Impl& m = *impl_;
  if (m.gray.size() == m.pixels && m.coverage.size() == m.pixels && m.depth.size() == m.pixels) return Status::Ok();
  Status s = m.gray.allocate(m.pixels, m.ctx);
  if (s.ok()) s = m.coverage.allocate(m.pixels, m.ctx);
  if (s.ok()) s = m.depth.allocate(m.pixels, m.ctx);
  if (!s.ok()) {  // nothing held on failure
    m.gray = DeviceBuffer<uint8_t>();
    m.coverage = DeviceBuffer<uint8_t>();
    m.depth = DeviceBuffer<float>();
  }
  return s;
}

Status DeviceSnapshots::take(const PixelBuffers& pixels) {
  Impl& m = *impl_;
  if (pixels.width != m.width || pixels.height != m.height || pixels.offset != m.offset)
    return invalid_argument("device snapshots: " + std::to_string(pixels.width.size()) +
                            " views handed over do not match the " + std::to_string(m.width.size()) + " views given");
  if (m.width.empty()) return Status::Ok();
  VPR_RETURN_IF_ERROR(m.check_device());
  VPR_RETURN_IF_ERROR(allocate());
  // Registered for this render only: the renderer deletes the buffers after.
  struct Registered {
    cudaGraphicsResource_t resource[2] = {nullptr, nullptr};
    ~Registered() {
      for (cudaGraphicsResource_t r : resource)
        if (r) cudaGraphicsUnregisterResource(r);
    }
  } reg;
  const unsigned names[2] = {pixels.rgba, pixels.depth};
  for (int i = 0; i < 2; ++i) {
    const cudaError_t err = cudaGraphicsGLRegisterBuffer(&reg.resource[i], names[i], cudaGraphicsRegisterFlagsReadOnly);
    if (err != cudaSuccess) {
      reg.resource[i] = nullptr;
      return interop_failed(err, "cudaGraphicsGLRegisterBuffer");
    }
  }
  const cudaStream_t stream = stream_of(m.ctx);
  cudaError_t err = cudaGraphicsMapResources(2, reg.resource, stream);
  if (err != cudaSuccess) return interop_failed(err, "cudaGraphicsMapResources");
  void* rgba = nullptr;
  void* depth = nullptr;
  size_t rgba_bytes = 0, depth_bytes = 0;
  err = cudaGraphicsResourceGetMappedPointer(&rgba, &rgba_bytes, reg.resource[0]);
  if (err == cudaSuccess) err = cudaGraphicsResourceGetMappedPointer(&depth, &depth_bytes, reg.resource[1]);
  const bool fits = rgba_bytes >= 4 * m.pixels && depth_bytes >= 4 * m.pixels;
  for (size_t v = 0; v < m.width.size() && err == cudaSuccess && fits; ++v) {
    const int w = m.width[v], h = m.height[v];
    const size_t o = m.offset[v];
    const dim3 block(32, 8), grid(unsigned((w + 31) / 32), unsigned((h + 7) / 8));
    snapshot_kernel<<<grid, block, 0, stream>>>(static_cast<const uint8_t*>(rgba) + 4 * o,
                                                static_cast<const float*>(depth) + o, w, h, m.gray.get() + o,
                                                m.depth.get() + o, m.coverage.get() + o);
    err = cudaGetLastError();
  }
  // Unmapping orders the kernels before GL's next use of the buffers.
  const cudaError_t unmapped = cudaGraphicsUnmapResources(2, reg.resource, stream);
  if (err != cudaSuccess) return interop_failed(err, "reading the mapped pixel buffers");
  if (!fits)
    return internal_error("GL-CUDA interop: pixel buffers of " + std::to_string(rgba_bytes) + " and " +
                          std::to_string(depth_bytes) + " bytes for " + std::to_string(m.pixels) + " pixels");
  if (unmapped != cudaSuccess) return interop_failed(unmapped, "cudaGraphicsUnmapResources");
  m.taken = true;
  return Status::Ok();
}

size_t DeviceSnapshots::size() const {
  return impl_->taken ? impl_->width.size() : 0;
}

DeviceSnapshot DeviceSnapshots::snapshot(size_t view) const {
  const Impl& m = *impl_;
  if (!m.taken || view >= m.width.size()) return {};
  const size_t o = m.offset[view];
  return {m.width[view], m.height[view], m.gray.get() + o, m.coverage.get() + o, m.depth.get() + o};
}

const float* DeviceSnapshots::depths() const {
  return impl_->same_size && impl_->taken ? impl_->depth.get() : nullptr;
}

Status DeviceSnapshots::download(std::vector<Snapshot>* out) const {
  const Impl& m = *impl_;
  const cudaStream_t stream = stream_of(m.ctx);
  out->assign(size(), Snapshot{});
  for (size_t v = 0; v < size(); ++v) {
    const int w = m.width[v], h = m.height[v];
    const size_t n = size_t(w) * size_t(h), o = m.offset[v];
    Snapshot& s = (*out)[v];
    s.gray = GrayImage(w, h, 0);
    s.coverage = Mask(w, h, 0);
    s.depth = FloatImage(w, h, 1.0f);
    VPR_CUDA_TRY(cudaMemcpyAsync(s.gray.pixels.data(), m.gray.get() + o, n, cudaMemcpyDeviceToHost, stream));
    VPR_CUDA_TRY(cudaMemcpyAsync(s.coverage.pixels.data(), m.coverage.get() + o, n, cudaMemcpyDeviceToHost, stream));
    VPR_CUDA_TRY(
        cudaMemcpyAsync(s.depth.pixels.data(), m.depth.get() + o, n * sizeof(float), cudaMemcpyDeviceToHost, stream));
  }
  VPR_CUDA_TRY(cudaStreamSynchronize(stream));
  return Status::Ok();
}

}  // namespace vpr::cuda
