// StepMarks: silent without VPREMESH_STEP_MARKS; with it, one line per scope
// naming each step in order with its time, a repeated step once per mark.
#include "core/step_marks.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

namespace vpr {
namespace {

TEST(StepMarks, OneLinePerScopeWithEachStepInOrder) {
  // Set before the first read: step_marks_on() reads the environment once.
  ::setenv("VPREMESH_STEP_MARKS", "1", 1);
  ASSERT_TRUE(step_marks_on());
  testing::internal::CaptureStderr();
  {
    StepMarks marks("scope");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    marks.mark("slow");
    marks.mark("quick");
    marks.mark("slow");
  }
  const std::string line = testing::internal::GetCapturedStderr();
  ASSERT_EQ(line.rfind("steps scope: slow ", 0), 0u) << line;
  EXPECT_EQ(line.back(), '\n');
  EXPECT_EQ(line.find('\n'), line.size() - 1) << "one line";
  const size_t quick = line.find(" quick ");
  ASSERT_NE(quick, std::string::npos);
  EXPECT_NE(line.find(" slow ", quick), std::string::npos) << "the repeated step marked again";
  // The first step's time covers the sleep.
  const double first = std::stod(line.substr(std::string("steps scope: slow ").size()));
  EXPECT_GE(first, 19.0);
  EXPECT_LT(first, 5000.0);
}

TEST(StepMarks, AScopeWithoutMarksPrintsNothing) {
  testing::internal::CaptureStderr();
  { StepMarks marks("empty"); }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace vpr
