// A visual target for a level of detail (issue 20): the fewest vertices whose
// output, rendered from the job's own views, keeps the mean SSIM against the
// input at or above a bound. Each try runs the back half at one count (the
// front half is shared), which costs about in proportion to the count, so the
// search starts low (1/64 of the range's top) and steps up by a model
// of the score against the count, 1 - SSIM ~ c n^-a (a line in log n,
// log(1 - SSIM)), fitted to the two tries nearest the bound and aimed 1% past
// it. Measured curves steepen towards the bound (about n^-0.65 from a few
// hundred vertices, n^-1 near 0.97: scripts/visual-curve.py), so a line
// through a try far below the bound steps as 1/n would at most, and from a
// failure near the bound the step may be as short as the tolerance, doubling
// after each such step that fails (near the bound the score is noisy: SSIM
// moves by about 0.001 between counts 1% apart). Once a count passes near
// the bound, the next try is the largest that would close the bracket within
// the tolerance (2%) if it fails; from a pass well above the bound (a cliff
// in the score, where a part appears) that the model cannot place, the
// bracket's middle. Tries stay strictly inside the bracket; it bisects when
// the bracket has not halved in two tries. vpremesh-visual-replay replays the
// search on measured curves (client/bench/visual_search_replay.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/status.h"

namespace vpr {

struct VisualTargetOptions {
  double min_ssim = 0.97;     // the bound, in (0, 1)
  uint32_t lowest = 100;      // the fewest vertices tried
  uint32_t highest = 100000;  // the most vertices tried
  uint32_t first = 0;         // the first try; 0: the geometric mean of lowest and highest
  double tolerance = 0.02;    // stop when the smallest passing count is within this of the largest failing one
  int max_tries = 12;         // a bound on the back halves run
};

struct VisualTry {
  uint32_t count = 0;
  double ssim = 0;
};

struct VisualTargetOutcome {
  uint32_t count = 0;            // the smallest count tried that reached the bound (the largest tried when none did)
  double ssim = 0;               // its score
  bool reached = false;          // false: even `highest` vertices stay below the bound (or the tries ran out first)
  std::vector<VisualTry> tries;  // in the order run
};

// The search, one try at a time: next() is the count to try (0: the search
// is over), record() its score. A copy given a score the try has not yet
// had says what the search would ask next after it: the tries made ahead
// (pipeline.cpp) ask for both outcomes of the try that runs.
class VisualSearch {
 public:
  // INVALID_ARGUMENT for a bound outside (0, 1) or an empty range.
  static StatusOr<VisualSearch> start(const VisualTargetOptions& options);
  uint32_t next() const { return done_ ? 0 : next_; }
  // The score of the try at next() (another count counts as that one's).
  void record(uint32_t count, double ssim);
  // What the search would try after the try at `count` scored `ssim` (0: it
  // would stop), the search itself unchanged.
  uint32_t next_after(uint32_t count, double ssim) const {
    VisualSearch after = *this;
    after.record(count, ssim);
    return after.next();
  }
  VisualTargetOutcome outcome() const;
  const VisualTargetOptions& options() const { return o_; }

 private:
  explicit VisualSearch(const VisualTargetOptions& options);
  bool bracket_closed() const;

  VisualTargetOptions o_;
  std::vector<VisualTry> tries_;
  // The bracket: the largest count that failed, the smallest that passed.
  uint32_t failed_ = 0, passed_ = 0;
  double passed_ssim_ = 0;
  uint32_t next_ = 0;
  bool done_ = false;
  int stalled_ = 0;  // tries since the bracket last halved in log width
  // Steps of less than 2 up from a failure near the bound, and how many of
  // them failed: each failure doubles the next such step.
  bool short_step_ = false;
  int short_steps_failed_ = 0;
  double width_ = 0;
};

// score(n): runs the back half at n vertices and returns its mean SSIM (the
// caller keeps the results it may hand back). Errors from score end the search.
StatusOr<VisualTargetOutcome> search_visual_target(const VisualTargetOptions& options,
                                                   const std::function<StatusOr<double>(uint32_t)>& score);

}  // namespace vpr
