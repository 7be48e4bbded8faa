// A typed device array drawn from the device's memory pool (cudaMallocAsync on
// the job's stream), so that a job's allocations cost no device-wide sync and
// freed memory is reused by the next job (cuda_device.h: init_device_pool keeps
// it cached). Every allocation is charged to the job's DeviceBudget.
#pragma once

#include <cuda_runtime.h>

#include <string>
#include <utility>
#include <vector>

#include "gpu/cuda_check.h"
#include "gpu/staged_upload.h"

namespace vpr::cuda {

template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept { *this = std::move(o); }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      std::swap(ptr_, o.ptr_);
      std::swap(count_, o.count_);
      std::swap(stream_, o.stream_);
      std::swap(budget_, o.budget_);
    }
    return *this;
  }
  ~DeviceBuffer() { release(); }

  // Replaces the contents with `count` uninitialized elements.
  Status allocate(size_t count, const ExecContext& ctx) {
    release();
    if (count == 0) return Status::Ok();
    const size_t bytes = count * sizeof(T);
    if (ctx.budget) {
      const size_t used = ctx.budget->used.fetch_add(bytes) + bytes;
      if (used > ctx.budget->limit) {
        ctx.budget->used.fetch_sub(bytes);
        return resource_exhausted("device memory: " + std::to_string(bytes >> 20) + " MiB more would pass the job's " +
                                  std::to_string(ctx.budget->limit >> 20) + " MiB budget");
      }
      size_t peak = ctx.budget->peak.load();
      while (used > peak && !ctx.budget->peak.compare_exchange_weak(peak, used)) {
      }
      budget_ = ctx.budget;
    }
    stream_ = stream_of(ctx);
    void* p = nullptr;
    const cudaError_t err = cudaMallocAsync(&p, bytes, stream_);
    if (err != cudaSuccess) {
      cudaGetLastError();
      if (budget_) budget_->used.fetch_sub(bytes);
      budget_ = nullptr;
      return cuda_status(err, "cudaMallocAsync");
    }
    ptr_ = static_cast<T*>(p);
    count_ = count;
    return Status::Ok();
  }

  // allocate(count) and copy `count` elements from host memory.
  Status upload(const T* host, size_t count, const ExecContext& ctx) {
    VPR_RETURN_IF_ERROR(allocate(count, ctx));
    if (count) VPR_RETURN_IF_ERROR(staged_upload(ptr_, host, count * sizeof(T), stream_));  // gpu/staged_upload.h
    return Status::Ok();
  }

  // Copies the first `count` elements to host memory (asynchronous on the
  // stream: synchronize before reading them).
  Status download(T* host, size_t count) const {
    if (count > count_) return internal_error("download of " + std::to_string(count) + " elements from a buffer of " +
                                              std::to_string(count_));
    if (count) VPR_CUDA_TRY(cudaMemcpyAsync(host, ptr_, count * sizeof(T), cudaMemcpyDeviceToHost, stream_));
    return Status::Ok();
  }

  Status zero() {
    if (count_) VPR_CUDA_TRY(cudaMemsetAsync(ptr_, 0, count_ * sizeof(T), stream_));
    return Status::Ok();
  }

  T* get() { return ptr_; }
  const T* get() const { return ptr_; }
  size_t size() const { return count_; }

 private:
  void release() {
    if (ptr_) {
      cudaFreeAsync(ptr_, stream_);  // stream-ordered: safe while kernels on it still run
      if (budget_) budget_->used.fetch_sub(count_ * sizeof(T));
    }
    ptr_ = nullptr;
    count_ = 0;
    budget_ = nullptr;
  }

  T* ptr_ = nullptr;
  size_t count_ = 0;
  cudaStream_t stream_ = nullptr;
  DeviceBudget* budget_ = nullptr;
};

// Several host arrays into their device buffers with one staged upload
// (gpu/staged_upload.h): add() allocates each buffer at once, run() copies
// them all. An allocation that fails is what run() returns.
class UploadBatch {
 public:
  explicit UploadBatch(const ExecContext& ctx) : ctx_(ctx) {}

  template <class T>
  UploadBatch& add(DeviceBuffer<T>* buffer, const T* host, size_t count) {
    if (!status_.ok()) return *this;
    status_ = buffer->allocate(count, ctx_);
    if (status_.ok() && count) parts_.push_back({buffer->get(), host, count * sizeof(T)});
    return *this;
  }

  Status run() {
    VPR_RETURN_IF_ERROR(status_);
    return staged_upload(parts_, stream_of(ctx_));
  }

 private:
  const ExecContext& ctx_;
  Status status_ = Status::Ok();
  std::vector<StagedPart> parts_;
};

}  // namespace vpr::cuda
