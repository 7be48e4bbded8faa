// Which CUDA devices this process can use. Safe to call on machines with no
// GPU or no driver: it reports zero devices and why.
#pragma once

#include <string>
#include <vector>

namespace vpr {

struct CudaDeviceInfo {
  int index = 0;
  std::string name;
  int sm_major = 0, sm_minor = 0;
  size_t total_memory = 0;
};

// Devices found, or an empty list with the CUDA error in *why.
std::vector<CudaDeviceInfo> cuda_devices(std::string* why);

}  // namespace vpr
