// Which CUDA devices this process can use, and the per-job stream. Safe to call
// on machines with no GPU or no driver: they report zero devices and why.
// Plain C++ (no CUDA headers), so the pipeline and the server can include it.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"

namespace vpr {

struct CudaDeviceInfo {
  int index = 0;
  std::string name;
  int sm_major = 0, sm_minor = 0;
  size_t total_memory = 0;
};

// Devices found, or an empty list with the CUDA error in *why.
std::vector<CudaDeviceInfo> cuda_devices(std::string* why);

// Makes `device` current on the calling thread and keeps freed memory of its
// default pool cached (release threshold = whole device), so a job's
// cudaMallocAsync reuses what the previous job freed instead of going back to
// the driver. Call once per worker thread before its first job.
Status init_cuda_device(int device);

// A non-blocking CUDA stream owned by one job (one stream per job lets several
// jobs share a GPU). Move-only; destroyed with the job.
class CudaStream {
 public:
  static StatusOr<CudaStream> create(int device);
  CudaStream() = default;
  CudaStream(CudaStream&& o) noexcept : stream_(o.stream_) { o.stream_ = nullptr; }
  CudaStream& operator=(CudaStream&& o) noexcept;
  CudaStream(const CudaStream&) = delete;
  CudaStream& operator=(const CudaStream&) = delete;
  ~CudaStream();

  void* get() const { return stream_; }  // cudaStream_t
  Status synchronize() const;

 private:
  void* stream_ = nullptr;
};

}  // namespace vpr
