#include "core/step_marks.h"

#include <cstdio>
#include <cstdlib>

namespace vpr {

bool step_marks_on() {
  static const bool on = [] {
    const char* v = std::getenv("VPREMESH_STEP_MARKS");
    return v && *v && std::string(v) != "0";
  }();
  return on;
}

StepMarks::StepMarks(const char* scope) : scope_(scope), on_(step_marks_on()) {
  if (on_) last_ = Clock::now();
}

void StepMarks::mark(const char* step) {
  if (!on_) return;
  const Clock::time_point now = Clock::now();
  steps_.push_back({step, std::chrono::duration<double, std::milli>(now - last_).count()});
  last_ = now;
}

StepMarks::~StepMarks() {
  if (!on_ || steps_.empty()) return;
  // One write, so lines of concurrent jobs do not interleave.
  std::string line = std::string("steps ") + scope_ + ":";
  char part[160];
  for (const auto& [step, ms] : steps_) {
    std::snprintf(part, sizeof part, " %s %.3f;", step, ms);
    line += part;
  }
  line += "\n";
  std::fputs(line.c_str(), stderr);
}

}  // namespace vpr
