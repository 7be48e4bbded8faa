// Where a stage runs. Every stage's CPU function takes one of these, and its
// GPU twin (vpr::cuda, same signature) reads the stream from it.
#pragma once

namespace vpr {

enum class Device { kCpu, kCuda };

struct ExecContext {
  Device device = Device::kCpu;
  void* stream = nullptr;  // cudaStream_t for the GPU twins; unused on the CPU
};

inline const char* device_name(Device d) {
  return d == Device::kCuda ? "cuda" : "cpu";
}

}  // namespace vpr
