// Error handling for CUDA calls (included by .cu files only). Every runtime
// call and every kernel launch is checked; a failure becomes a Status that names
// the call, so the pipeline can rerun the stage on the CPU and say why.
#pragma once

#include <cuda_runtime.h>

#include <string>

#include "core/exec_context.h"
#include "core/status.h"

namespace vpr::cuda {

// Out of memory maps to RESOURCE_EXHAUSTED (the job may still succeed on the
// CPU); everything else is INTERNAL.
inline Status cuda_status(cudaError_t err, const char* what) {
  const std::string message = std::string(what) + ": " + cudaGetErrorName(err) + " (" + cudaGetErrorString(err) + ")";
  if (err == cudaErrorMemoryAllocation) return resource_exhausted("device out of memory in " + message);
  return internal_error("CUDA error in " + message);
}

inline cudaStream_t stream_of(const ExecContext& ctx) {
  return static_cast<cudaStream_t>(ctx.stream);
}

// Threads per block for 1D launches and the block count that covers n items.
inline constexpr int kBlock = 256;
inline unsigned blocks_for(size_t n, int block = kBlock) {
  return unsigned((n + block - 1) / block);
}

}  // namespace vpr::cuda

// Returns the Status from the enclosing function when a CUDA call fails.
#define VPR_CUDA_TRY(expr)                                                       \
  do {                                                                           \
    const cudaError_t vpr_cuda_err_ = (expr);                                    \
    if (vpr_cuda_err_ != cudaSuccess) return ::vpr::cuda::cuda_status(vpr_cuda_err_, #expr); \
  } while (0)

// After a kernel launch: catches bad launch configurations at once; errors
// inside the kernel surface at the next synchronizing call, which is checked too.
#define VPR_CUDA_LAUNCHED(name)                                                      \
  do {                                                                               \
    const cudaError_t vpr_cuda_err_ = cudaGetLastError();                            \
    if (vpr_cuda_err_ != cudaSuccess) return ::vpr::cuda::cuda_status(vpr_cuda_err_, "launch of " name); \
  } while (0)
