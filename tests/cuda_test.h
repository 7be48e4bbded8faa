// The GPU twins' test fixture: skipped where no CUDA device answers; else
// device 0 initialized and a stream of the test's own in gpu_.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "core/exec_context.h"
#include "gpu/cuda_device.h"

namespace vpr {

class CudaTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (cuda_devices(&why).empty()) GTEST_SKIP() << why;
    ASSERT_TRUE(init_cuda_device(0).ok());
    auto stream = CudaStream::create(0);
    ASSERT_TRUE(stream.ok()) << stream.status().to_string();
    stream_ = std::move(stream).value();
    gpu_ = ExecContext{Device::kCuda, stream_.get(), nullptr};
  }

  CudaStream stream_;
  ExecContext gpu_;
};

}  // namespace vpr
