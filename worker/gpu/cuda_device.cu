#include <cuda_runtime.h>

#include <cstdint>
#include <utility>

#include "gpu/cuda_check.h"
#include "gpu/cuda_device.h"

namespace vpr {

std::vector<CudaDeviceInfo> cuda_devices(std::string* why) {
  std::vector<CudaDeviceInfo> out;
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess) {
    if (why) *why = std::string("no usable CUDA device: ") + cudaGetErrorString(err);
    cudaGetLastError();  // clear the sticky error so later calls start clean
    return out;
  }
  for (int i = 0; i < count; ++i) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, i) != cudaSuccess) continue;
    out.push_back({i, prop.name, prop.major, prop.minor, prop.totalGlobalMem});
  }
  if (out.empty() && why) *why = "no CUDA device found";
  return out;
}

Status init_cuda_device(int device) {
  VPR_CUDA_TRY(cudaSetDevice(device));
  cudaMemPool_t pool;
  VPR_CUDA_TRY(cudaDeviceGetDefaultMemPool(&pool, device));
  uint64_t keep = UINT64_MAX;  // never hand freed pool memory back to the driver
  VPR_CUDA_TRY(cudaMemPoolSetAttribute(pool, cudaMemPoolAttrReleaseThreshold, &keep));
  return Status::Ok();
}

StatusOr<CudaStream> CudaStream::create(int device) {
  VPR_CUDA_TRY(cudaSetDevice(device));
  cudaStream_t s = nullptr;
  VPR_CUDA_TRY(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking));
  CudaStream out;
  out.stream_ = s;
  return StatusOr<CudaStream>(std::move(out));
}

CudaStream& CudaStream::operator=(CudaStream&& o) noexcept {
  if (this != &o) {
    if (stream_) cudaStreamDestroy(static_cast<cudaStream_t>(stream_));
    stream_ = o.stream_;
    o.stream_ = nullptr;
  }
  return *this;
}

CudaStream::~CudaStream() {
  if (stream_) cudaStreamDestroy(static_cast<cudaStream_t>(stream_));
}

Status CudaStream::synchronize() const {
  VPR_CUDA_TRY(cudaStreamSynchronize(static_cast<cudaStream_t>(stream_)));
  return Status::Ok();
}

}  // namespace vpr
