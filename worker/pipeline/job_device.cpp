#include "job_device.h"

#include <mutex>
#include <vector>

#include "pipeline.h"
#ifdef VPR_HAVE_CUDA
#include "gpu/cuda_device.h"
#endif

namespace vpr {

#ifdef VPR_HAVE_CUDA
struct JobDevice::Stream {
  CudaStream stream;
  CudaStream beside;
  CudaStream ahead;
};

namespace {
// Probed once per process: the driver's answer does not change while we run.
const std::vector<CudaDeviceInfo>& probed_devices(std::string* why) {
  static std::once_flag once;
  static std::vector<CudaDeviceInfo> devices;
  static std::string reason;
  std::call_once(once, [] { devices = cuda_devices(&reason); });
  *why = reason;
  return devices;
}
}  // namespace
#else
struct JobDevice::Stream {};
#endif

JobDevice::~JobDevice() = default;

StatusOr<std::unique_ptr<JobDevice>> JobDevice::select(DevicePolicy policy, int cuda_device, DeviceBudget* budget) {
  std::unique_ptr<JobDevice> job(new JobDevice());
  if (policy == DevicePolicy::kCpu) return job;
#ifdef VPR_HAVE_CUDA
  std::string why;
  const auto& devices = probed_devices(&why);
  Status status = Status::Ok();
  if (devices.empty()) {
    status = unavailable(why);
  } else if (cuda_device < 0 || size_t(cuda_device) >= devices.size()) {
    status = unavailable("CUDA device " + std::to_string(cuda_device) + " does not exist; this machine has " +
                         std::to_string(devices.size()));
  } else {
    status = init_cuda_device(cuda_device);
    if (status.ok()) {
      auto stream = CudaStream::create(cuda_device);
      auto beside = CudaStream::create(cuda_device);
      auto ahead = CudaStream::create(cuda_device);
      if (stream.ok() && beside.ok() && ahead.ok()) {
        job->stream_ = std::make_unique<Stream>(
            Stream{std::move(stream).value(), std::move(beside).value(), std::move(ahead).value()});
        job->ctx_ = {Device::kCuda, job->stream_->stream.get(), budget};
        job->beside_ctx_ = {Device::kCuda, job->stream_->beside.get(), budget};
        job->ahead_ctx_ = {Device::kCuda, job->stream_->ahead.get(), budget};
        job->cuda_device_ = cuda_device;
        job->description_ = "cuda:" + std::to_string(cuda_device) + " " + devices[size_t(cuda_device)].name;
        return job;
      }
      status = !stream.ok() ? stream.status() : !beside.ok() ? beside.status() : ahead.status();
    }
  }
  if (policy == DevicePolicy::kCuda) return Status(StatusCode::kUnavailable, "GPU required but " + status.message());
  job->cpu_reason_ = status.message();
#else
  (void)cuda_device;
  (void)budget;
  if (policy == DevicePolicy::kCuda)
    return unavailable("GPU required but this build has no CUDA twins (built without nvcc)");
  job->cpu_reason_ = "built without CUDA";
#endif
  return job;
}

Status JobDevice::use_on_this_thread() const {
#ifdef VPR_HAVE_CUDA
  if (stream_) return init_cuda_device(cuda_device_);
#endif
  return Status::Ok();
}

Status JobDevice::synchronize() const {
#ifdef VPR_HAVE_CUDA
  if (stream_) return stream_->stream.synchronize();
#endif
  return Status::Ok();
}

}  // namespace vpr
