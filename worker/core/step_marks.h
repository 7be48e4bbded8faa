// Where a stage's time goes, step by step, for measuring only: a StepMarks
// made while the environment sets VPREMESH_STEP_MARKS prints, when it goes
// out of scope, one line to stderr, "steps <scope>: <step> <ms>; ...", each
// step's wall time from the mark before it (or from the start). Unset, it
// reads no clock and prints nothing. The per-step tables of
// docs/performance.md come from these lines (scripts/step-marks.py).
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace vpr {

class StepMarks {
 public:
  explicit StepMarks(const char* scope);
  ~StepMarks();
  StepMarks(const StepMarks&) = delete;
  StepMarks& operator=(const StepMarks&) = delete;
  // The time since the last mark, as `step` (a literal: kept by pointer).
  void mark(const char* step);
  bool on() const { return on_; }

 private:
  using Clock = std::chrono::steady_clock;
  const char* scope_;
  bool on_;
  Clock::time_point last_;
  std::vector<std::pair<const char*, double>> steps_;
};

// Whether VPREMESH_STEP_MARKS is set (read once).
bool step_marks_on();

}  // namespace vpr
