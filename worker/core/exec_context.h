// Where a stage runs. Every stage's CPU function takes one of these, and its
// GPU twin (vpr::cuda, same signature) reads the stream and the job's device
// memory budget from it.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace vpr {

enum class Device { kCpu, kCuda };

// Device memory one job may hold at once. DeviceBuffer (gpu/device_buffer.h)
// charges every allocation here and refuses one that would pass the limit with
// RESOURCE_EXHAUSTED, so that several jobs can share a GPU without one of them
// starving the others; the stage then reruns on the CPU.
struct DeviceBudget {
  size_t limit = SIZE_MAX;  // bytes
  std::atomic<size_t> used{0};
  std::atomic<size_t> peak{0};
};

struct ExecContext {
  Device device = Device::kCpu;
  void* stream = nullptr;          // cudaStream_t for the GPU twins; unused on the CPU
  DeviceBudget* budget = nullptr;  // null: no per-job limit (the pool still bounds it)
};

inline const char* device_name(Device d) {
  return d == Device::kCuda ? "cuda" : "cpu";
}

}  // namespace vpr
