// Host-to-device copies of large pageable buffers through pinned staging
// memory. A pageable cudaMemcpyAsync goes through the driver's own bounce
// buffer with one thread copying into it: 6-8 GB/s for 55 MB on the H200
// host, where DMA from pinned memory runs at 55 GB/s (docs/performance.md;
// the CVT alone uploaded 55 MB on igea, 8.6 ms). Here the buffer is cut into
// 1 MiB chunks, and the job's threads take them in parallel: each copies its
// chunk into a slot of a process-wide pinned pool, queues the slot's DMA on
// the job's stream and an event behind it, and puts the slot back; the next
// taker waits on that event before writing. The chunks' DMAs land in any
// order; they write disjoint ranges, and all of them are queued before the
// call returns, so work queued later on the stream sees the whole buffer.
//
// The same contract as cudaMemcpyAsync from pageable memory: in stream
// order, and the host buffer may be changed or freed once the call returns.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <vector>

#include "core/status.h"

namespace vpr::cuda {

// Below this a copy goes straight to cudaMemcpyAsync (the chunking would cost
// more than it saves).
inline constexpr size_t kStagedUploadFrom = size_t(1) << 20;
// The pool: slots of 1 MiB, 64 of them (64 MiB pinned per process, allocated
// at the first large upload; if that fails every copy goes straight), taken
// oldest-returned first, so a slot's last DMA is long done when it is reused.
inline constexpr size_t kStagingSlotBytes = size_t(1) << 20;
inline constexpr int kStagingSlots = 64;

Status staged_upload(void* device, const void* host, size_t bytes, cudaStream_t stream);

// Several copies at once, their chunks taken by the threads together: a
// stage that uploads a dozen arrays of a few MB each pays for the threads'
// start once, and its DMAs follow one another without a gap (each array
// alone would be little faster than straight). Every part is chunked,
// whatever its size.
struct StagedPart {
  void* device;
  const void* host;
  size_t bytes;
};
Status staged_upload(const std::vector<StagedPart>& parts, cudaStream_t stream);

// How many bytes went through the pool and how many straight, since the
// process started (the tests read these).
struct StagedUploadCounts {
  size_t staged = 0;
  size_t direct = 0;
};
StagedUploadCounts staged_upload_counts();

}  // namespace vpr::cuda
