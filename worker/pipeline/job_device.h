// Where one job's parallel stages run (the fallback order of the GPU issue):
// built without CUDA, or no usable device -> the CPU twins; otherwise a CUDA
// stream of the job's own on the chosen GPU, so that several jobs can share it.
#pragma once

#include <memory>
#include <string>

#include "core/exec_context.h"
#include "core/status.h"

namespace vpr {

enum class DevicePolicy;

class JobDevice {
 public:
  // kCpu -> the CPU. kAuto -> a GPU if the build has the twins and device
  // `cuda_device` answers, else the CPU with the reason in cpu_reason().
  // kCuda -> that GPU or UNAVAILABLE naming why there is none.
  static StatusOr<std::unique_ptr<JobDevice>> select(DevicePolicy policy, int cuda_device, DeviceBudget* budget);
  ~JobDevice();

  const ExecContext& context() const { return ctx_; }
  // A second stream of the job's, for work made on another thread beside
  // the stages (the refinement ahead of the density stage), so its waits do
  // not wait for the stages' kernels; the same memory budget. That thread
  // calls use_on_this_thread() first. On the CPU: the CPU context.
  const ExecContext& beside_context() const { return beside_ctx_; }
  // A third, for the curvature made beside stages 1-3 on a thread of its
  // own while the refinement uses the second.
  const ExecContext& ahead_context() const { return ahead_ctx_; }
  Status use_on_this_thread() const;
  bool on_gpu() const { return ctx_.device == Device::kCuda; }
  const std::string& description() const { return description_; }  // "cpu" or "cuda:0 NVIDIA H100 ..."
  const std::string& cpu_reason() const { return cpu_reason_; }    // empty on the GPU or when asked for the CPU
  // Waits for the job's stream (no-op on the CPU).
  Status synchronize() const;

 private:
  JobDevice() = default;
  ExecContext ctx_;
  ExecContext beside_ctx_;
  ExecContext ahead_ctx_;
  int cuda_device_ = -1;
  std::string description_ = "cpu";
  std::string cpu_reason_;
  struct Stream;
  std::unique_ptr<Stream> stream_;
};

}  // namespace vpr
