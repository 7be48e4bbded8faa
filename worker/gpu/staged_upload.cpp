#include "gpu/staged_upload.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <vector>

#include "gpu/cuda_check.h"

namespace vpr::cuda {
namespace {

// Devices a process may stage for (a slot keeps one event per device: an
// event is recorded only on a stream of the device it was made on).
constexpr int kStagingDevices = 16;

// The slots, handed out oldest-returned first: a slot comes back to the
// queue as soon as its DMA is queued, with an event recorded behind that
// DMA, and whoever takes it next waits on the event before writing (with 64
// slots it has long been done). No host function in the stream: those hold
// the stream until they run, tens of microseconds a chunk.
class StagingPool {
 public:
  // The slot that came back longest ago; -1 when there is no pinned memory
  // (its allocation failed: copy straight).
  int take() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!tried_) {
      tried_ = true;
      void* p = nullptr;
      if (cudaHostAlloc(&p, kStagingSlotBytes * kStagingSlots, cudaHostAllocPortable) == cudaSuccess) {
        base_ = static_cast<char*>(p);
        for (int s = 0; s < kStagingSlots; ++s) queue_.push_back(s);
      } else {
        cudaGetLastError();  // clear it: the job's next call must not see this failure
      }
    }
    if (!base_) return -1;
    ready_.wait(lock, [&] { return !queue_.empty(); });  // empty only with more than 64 threads staging
    const int slot = queue_.front();
    queue_.pop_front();
    return slot;
  }

  // Waits until the slot's last DMA has read it. The taker alone touches a
  // slot's fields until it gives the slot back.
  Status wait_idle(int s) {
    Slot& slot = slots_[s];
    if (slot.pending_device < 0) return Status::Ok();
    const cudaError_t err = cudaEventSynchronize(slot.done[slot.pending_device]);
    slot.pending_device = -1;
    if (err != cudaSuccess) return cuda_status(err, "staged upload: waiting for a slot");
    return Status::Ok();
  }

  // Puts the slot back behind its queued DMA on `stream` (of `device`, the
  // current one): an event recorded there, or, if that fails, the stream
  // waited for.
  Status give_back(int s, int device, cudaStream_t stream) {
    Slot& slot = slots_[s];
    cudaError_t err = cudaSuccess;
    if (!slot.done[device]) err = cudaEventCreateWithFlags(&slot.done[device], cudaEventDisableTiming);
    if (err == cudaSuccess) err = cudaEventRecord(slot.done[device], stream);
    if (err == cudaSuccess) {
      slot.pending_device = device;
    } else {
      cudaStreamSynchronize(stream);
      cudaGetLastError();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(s);
    }
    ready_.notify_one();
    if (err != cudaSuccess) return cuda_status(err, "staged upload: the slot's event");
    return Status::Ok();
  }

  char* data(int s) const { return base_ + size_t(s) * kStagingSlotBytes; }

  // The pinned memory and events are never freed: the pool lives as long as
  // the process (freeing them at exit would race the driver's own teardown).
  static StagingPool& get() {
    static StagingPool* pool = new StagingPool;
    return *pool;
  }

  std::atomic<size_t> staged{0}, direct{0};

 private:
  struct Slot {
    cudaEvent_t done[kStagingDevices] = {};
    int pending_device = -1;
  };
  std::mutex mutex_;
  std::condition_variable ready_;
  bool tried_ = false;
  char* base_ = nullptr;
  std::deque<int> queue_;
  Slot slots_[kStagingSlots];
};

// One chunk: into a slot, its DMA queued on the stream of `device` (current).
Status upload_chunk(char* device_dst, const char* host, size_t n, int device, cudaStream_t stream) {
  StagingPool& pool = StagingPool::get();
  const int slot = device < kStagingDevices ? pool.take() : -1;
  if (slot < 0) {  // no pinned memory: straight
    pool.direct += n;
    VPR_CUDA_TRY(cudaMemcpyAsync(device_dst, host, n, cudaMemcpyHostToDevice, stream));
    return Status::Ok();
  }
  Status waited = pool.wait_idle(slot);
  if (!waited.ok()) {
    (void)pool.give_back(slot, device, stream);
    return waited;
  }
  char* staging = pool.data(slot);
  std::memcpy(staging, host, n);
  const cudaError_t err = cudaMemcpyAsync(device_dst, staging, n, cudaMemcpyHostToDevice, stream);
  Status back = pool.give_back(slot, device, stream);
  if (err != cudaSuccess) return cuda_status(err, "staged upload");
  VPR_RETURN_IF_ERROR(back);
  pool.staged += n;
  return Status::Ok();
}

}  // namespace

Status staged_upload(void* device, const void* host, size_t bytes, cudaStream_t stream) {
  if (bytes == 0) return Status::Ok();
  if (bytes < kStagedUploadFrom) {
    StagingPool::get().direct += bytes;
    VPR_CUDA_TRY(cudaMemcpyAsync(device, host, bytes, cudaMemcpyHostToDevice, stream));
    return Status::Ok();
  }
  return staged_upload({{device, host, bytes}}, stream);
}

Status staged_upload(const std::vector<StagedPart>& parts, cudaStream_t stream) {
  // Chunks first[p] .. first[p + 1] are part p's: chunk c at byte (c - first[p]) * slot of it.
  std::vector<size_t> first(parts.size() + 1, 0);
  for (size_t p = 0; p < parts.size(); ++p)
    first[p + 1] = first[p] + (parts[p].bytes + kStagingSlotBytes - 1) / kStagingSlotBytes;
  const size_t chunks = first.back();
  if (chunks == 0) return Status::Ok();
  // The threads that take chunks queue DMAs on the caller's stream, so they
  // work on the caller's device while they do (and go back to their own).
  int caller_device = 0;
  VPR_CUDA_TRY(cudaGetDevice(&caller_device));
  std::mutex failure_mutex;
  Status failure = Status::Ok();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1), [&](const tbb::blocked_range<size_t>& r) {
    int own_device = caller_device;
    cudaGetDevice(&own_device);
    if (own_device != caller_device) cudaSetDevice(caller_device);
    size_t p = size_t(std::upper_bound(first.begin(), first.end(), r.begin()) - first.begin()) - 1;
    for (size_t c = r.begin(); c != r.end(); ++c) {
      while (c >= first[p + 1]) ++p;
      const StagedPart& part = parts[p];
      const size_t at = (c - first[p]) * kStagingSlotBytes, n = std::min(kStagingSlotBytes, part.bytes - at);
      Status s = upload_chunk(static_cast<char*>(part.device) + at, static_cast<const char*>(part.host) + at, n,
                              caller_device, stream);
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (failure.ok()) failure = std::move(s);
      }
    }
    if (own_device != caller_device) cudaSetDevice(own_device);
  });
  return failure;
}

StagedUploadCounts staged_upload_counts() {
  StagingPool& pool = StagingPool::get();
  return {pool.staged.load(), pool.direct.load()};
}

}  // namespace vpr::cuda
