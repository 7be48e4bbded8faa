// Device selection and the fallback order of the GPU issue, as seen from a
// machine without a usable GPU (CI): auto runs on the CPU and says why, a
// required GPU is refused with the reason, and every stage then reports "cpu".
#include <gtest/gtest.h>

#include "pipeline/pipeline.h"
#include "test_meshes.h"

namespace vpr {
namespace {

bool machine_has_gpu() {
  auto device = JobDevice::select(DevicePolicy::kAuto, 0, nullptr);
  return device.ok() && (*device)->on_gpu();
}

TEST(JobDevice, CpuPolicyNeverTouchesTheGpu) {
  auto device = JobDevice::select(DevicePolicy::kCpu, 0, nullptr);
  ASSERT_TRUE(device.ok());
  EXPECT_FALSE((*device)->on_gpu());
  EXPECT_EQ((*device)->description(), "cpu");
  EXPECT_EQ((*device)->context().device, Device::kCpu);
  EXPECT_TRUE((*device)->cpu_reason().empty());
}

TEST(JobDevice, WithoutAGpuAutoFallsBackToTheCpuAndRequiredIsRefused) {
  if (machine_has_gpu()) GTEST_SKIP() << "this machine has a GPU; the gpu-labelled tests cover it";
  auto automatic = JobDevice::select(DevicePolicy::kAuto, 0, nullptr);
  ASSERT_TRUE(automatic.ok());
  EXPECT_FALSE((*automatic)->on_gpu());
  EXPECT_FALSE((*automatic)->cpu_reason().empty()) << "auto must say why it chose the CPU";

  auto required = JobDevice::select(DevicePolicy::kCuda, 0, nullptr);
  ASSERT_FALSE(required.ok());
  EXPECT_EQ(required.status().code(), StatusCode::kUnavailable);
  EXPECT_NE(required.status().message().find("GPU required"), std::string::npos) << required.status().message();
}

TEST(JobDevice, PipelineOnAutoWithoutAGpuRunsEveryStageOnTheCpu) {
  if (machine_has_gpu()) GTEST_SKIP() << "this machine has a GPU; the gpu-labelled tests cover it";
  PipelineOptions options;
  options.target_vertices = 300;
  options.device = DevicePolicy::kAuto;
  std::vector<std::string> streamed;
  options.on_stage = [&](const StageTiming& t) { streamed.push_back(t.name); };
  auto result = run_pipeline(vpr::testing::icosphere(3), options);
  ASSERT_TRUE(result.ok()) << result.status().to_string();
  EXPECT_EQ(result->device, "cpu");
  EXPECT_FALSE(result->cpu_reason.empty());
  ASSERT_EQ(streamed.size(), result->stages.size()) << "on_stage must see every stage, render included";
  for (size_t i = 0; i < streamed.size(); ++i) EXPECT_EQ(streamed[i], result->stages[i].name);
  for (const StageTiming& t : result->stages)
    if (t.name != "render") EXPECT_EQ(t.device, "cpu") << t.name;
}

}  // namespace
}  // namespace vpr
