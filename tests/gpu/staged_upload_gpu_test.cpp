// Uploads through the pinned staging pool (gpu/staged_upload.h): every byte
// arrives, at every size around the chunk and pool limits; the host buffer may
// be overwritten as soon as the call returns (cudaMemcpyAsync's contract);
// eight threads on eight streams at once share the pool and each gets its own
// bytes. Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <cstdint>
#include <thread>
#include <vector>

#include "cuda_test.h"
#include "gpu/cuda_device.h"
#include "gpu/device_buffer.h"
#include "gpu/staged_upload.h"

namespace vpr {
namespace {

class StagedUpload : public CudaTest {};

std::vector<uint8_t> pattern(size_t n, uint32_t seed) {
  std::vector<uint8_t> bytes(n);
  uint32_t x = seed * 2654435761u + 1;
  for (size_t i = 0; i < n; ++i) {
    x = x * 1664525u + 1013904223u;
    bytes[i] = uint8_t(x >> 24);
  }
  return bytes;
}

// Uploads `bytes`, overwrites the host copy at once, and reads the device's back.
std::vector<uint8_t> round_trip(const std::vector<uint8_t>& bytes, const ExecContext& ctx, uint32_t seed) {
  std::vector<uint8_t> host = bytes;
  cuda::DeviceBuffer<uint8_t> device;
  EXPECT_TRUE(device.upload(host.data(), host.size(), ctx).ok());
  std::fill(host.begin(), host.end(), uint8_t(seed));  // the contract: the source is free once upload returns
  std::vector<uint8_t> back(bytes.size());
  EXPECT_TRUE(device.download(back.data(), back.size()).ok());
  EXPECT_EQ(cudaStreamSynchronize(static_cast<cudaStream_t>(ctx.stream)), cudaSuccess);
  return back;
}

TEST_F(StagedUpload, EveryByteArrivesAtEverySize) {
  const size_t slot = cuda::kStagingSlotBytes, pool = slot * cuda::kStagingSlots;
  const cuda::StagedUploadCounts before = cuda::staged_upload_counts();
  size_t large = 0;
  for (size_t n : {size_t(1), size_t(4097), cuda::kStagedUploadFrom - 1, cuda::kStagedUploadFrom, slot - 1, slot,
                   slot + 3, 3 * slot + 12345, pool + slot / 2, 2 * pool + 7}) {
    const std::vector<uint8_t> bytes = pattern(n, uint32_t(n));
    const std::vector<uint8_t> back = round_trip(bytes, gpu_, 0xA5);
    EXPECT_TRUE(back == bytes) << n << " bytes";
    if (n >= cuda::kStagedUploadFrom) large += n;
  }
  // The large ones went through the pool, the small ones straight.
  const cuda::StagedUploadCounts after = cuda::staged_upload_counts();
  EXPECT_EQ(after.staged - before.staged, large);
}

TEST_F(StagedUpload, EightStreamsAtOnceGetTheirOwnBytes) {
  constexpr int kThreads = 8, kRounds = 4;
  std::vector<int> wrong(kThreads, 0), failed(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      if (!init_cuda_device(0).ok()) {
        failed[t] = 1;
        return;
      }
      auto stream = CudaStream::create(0);
      if (!stream.ok()) {
        failed[t] = 1;
        return;
      }
      const ExecContext ctx{Device::kCuda, stream->get(), nullptr};
      for (int r = 0; r < kRounds; ++r) {
        const size_t n = (size_t(9) << 20) + size_t(t) * 4099 + size_t(r);  // several slots each
        const std::vector<uint8_t> bytes = pattern(n, uint32_t(100 * t + r));
        wrong[t] += round_trip(bytes, ctx, uint32_t(t)) != bytes;
      }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_EQ(failed[t], 0) << "thread " << t;
    EXPECT_EQ(wrong[t], 0) << "thread " << t;
  }
}

}  // namespace
}  // namespace vpr
