#include "visual_target.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace vpr {
namespace {

// log(1 - SSIM), floored so that a perfect score stays finite.
double error_of(double ssim) {
  return std::log(std::max(1.0 - ssim, 1e-9));
}

}  // namespace

StatusOr<VisualTargetOutcome> search_visual_target(const VisualTargetOptions& o,
                                                   const std::function<StatusOr<double>(uint32_t)>& score) {
  if (!(o.min_ssim > 0 && o.min_ssim < 1)) return invalid_argument("minimum SSIM must be in (0, 1)");
  if (o.lowest < 1 || o.highest < o.lowest) return invalid_argument("the visual target's count range is empty");
  VisualTargetOutcome out;
  const double goal = error_of(o.min_ssim);
  // The bracket: the largest count that failed, the smallest that passed.
  uint32_t failed = 0, passed = 0;
  double passed_ssim = 0;
  auto done = [&]() {
    if (passed == o.lowest) return true;   // nothing smaller is allowed
    if (failed == o.highest) return true;  // nothing larger is allowed
    return passed > 0 && failed > 0 && double(passed) <= double(failed) * (1.0 + o.tolerance);
  };
  // The first try is cheap and low: a back half costs about its count, so
  // trying from below and stepping up by the model spends least.
  uint32_t next = o.first > 0 ? o.first : std::max(o.lowest, o.highest / 64);
  int stalled = 0;  // tries since the bracket last halved in log width
  // Steps of less than 2 up from a failure near the bound (see below), and
  // how many of them failed: each failure doubles the next such step.
  bool short_step = false;
  int short_steps_failed = 0;
  double width = std::log(double(o.highest)) - std::log(double(o.lowest)) + 1.0;
  while (int(out.tries.size()) < o.max_tries) {
    next = std::clamp(next, o.lowest, o.highest);
    VPR_ASSIGN_OR_RETURN(const double s, score(next));
    out.tries.push_back({next, s});
    if (short_step && s < o.min_ssim) ++short_steps_failed;
    short_step = false;
    if (s >= o.min_ssim) {
      if (passed == 0 || next < passed) passed = next, passed_ssim = s;
    } else if (next > failed) {
      failed = next;
    }
    if (done()) break;
    const double lo = failed > 0 ? std::log(failed) : std::log(o.lowest) - 1e-9;
    const double hi = passed > 0 ? std::log(passed) : std::log(o.highest) + 1e-9;
    if (passed > 0 && failed > 0) {
      if (hi - lo < 0.5 * width) {
        width = hi - lo;
        stalled = 0;
      } else {
        ++stalled;
      }
    }

    // The model through the two tries whose errors are nearest the goal.
    std::vector<VisualTry> near = out.tries;
    std::sort(near.begin(), near.end(), [&](const VisualTry& a, const VisualTry& b) {
      const double da = std::fabs(error_of(a.ssim) - goal), db = std::fabs(error_of(b.ssim) - goal);
      return da != db ? da < db : a.count < b.count;
    });
    const VisualTry& a = near[0];
    const VisualTry* b = nullptr;
    for (size_t i = 1; i < near.size() && !b; ++i)
      if (near[i].count != a.count) b = &near[i];
    const double slope = b ? (error_of(b->ssim) - error_of(a.ssim)) / (std::log(b->count) - std::log(a.count)) : 0;
    // One try, or a score that falls slower than n^-1/4 here (no surface's
    // does: its error falls about as n^-1/2; a flatter line is two noisy
    // scores, and its step would go to the range's end): assume
    // 1 - SSIM ~ 1/n, so that the next try falls short rather than past the
    // answer, where tries cost more.
    double rate = b && slope < -0.25 ? slope : -1.0;
    // Below the bound with no pass yet, a line through a try far from it (an
    // error over twice the goal's) is a chord of a curve that steepens
    // towards the bound (measured: about n^-0.65 from a few hundred vertices
    // to 0.94, n^-1 near 0.97), and its step overshoots by a third to
    // four-fifths, the costliest try of the search. Such a step takes the
    // 1/n model's instead, at most as long.
    const bool far = b && std::max(error_of(a.ssim), error_of(b->ssim)) > goal + std::log(2.0);
    if (passed == 0 && far) rate = std::min(rate, -1.0);
    // Aim a little past the predicted count, so that the try near the answer
    // passes and one more just inside the tolerance below it can close.
    double log_next = std::log(a.count) + (goal - error_of(a.ssim)) / rate + 0.5 * o.tolerance;
    // One-sided: at least a factor 2 and at most 16 past the known end;
    // two-sided: the bracket's middle when the model points outside it or
    // has not halved it in two tries. (Bisecting as soon as two tries
    // disagree, a larger count scoring lower, cost most where the bracket's
    // low end was a try far below the bound: on five measured curves,
    // replayed, 5.1 back halves a search on the mean against 4.8 without.)
    if (failed == 0) log_next = std::clamp(log_next, hi - std::log(16.0), hi - std::log(2.0));
    // One-sided from below: at least a factor 2 past the highest failure,
    // unless the try nearest the bound lies near it (an error within twice
    // the goal's, and a second try to fit a line through): then the step
    // may be as short as the tolerance, doubled (in log) after each such
    // step that failed, so that noise near the bound cannot make it creep;
    // and the first time, where the model points within the tolerance, the
    // largest count that ends the search if it passes.
    const bool trust_short = b && error_of(a.ssim) <= goal + std::log(2.0);
    const double shortest =
        trust_short ? std::min(std::log1p(o.tolerance) * std::ldexp(1.0, short_steps_failed), std::log(2.0))
                    : std::log(2.0);
    bool open_below = false;  // try the largest count that ends the search if it passes
    if (passed == 0) {  // then failed > 0: every try failed
      open_below = trust_short && short_steps_failed == 0 && log_next <= lo + shortest + 1e-9;
      log_next = std::clamp(log_next, lo + shortest, lo + std::log(16.0));
      short_step = trust_short && log_next < lo + std::log(2.0) - 1e-9;
    }
    // Close from above: the largest count that would end the search if it fails.
    const double closing = hi - std::log1p(o.tolerance) + 1e-9;
    if (passed > 0 && log_next >= closing) log_next = closing;
    // Close from below: when the last try failed although the model aimed it
    // past the bound, and the model now points within the tolerance above
    // that failure, try the largest count that ends the search if it
    // passes. Near the bound the score is noisy (SSIM moves by about 0.002
    // between counts 1% apart), and creeping up from the failure by the
    // model's small steps would fail again and again.
    const double opening = lo + std::log1p(o.tolerance) - 1e-9;
    const bool close_from_below = passed > 0 && failed > 0 && out.tries.back().ssim < o.min_ssim &&
                                  log_next > lo && log_next <= opening;
    if (passed > 0 && failed > 0 && (stalled >= 2 || log_next <= lo)) {
      log_next = 0.5 * (lo + hi);
      stalled = 0;
    }
    uint32_t n = uint32_t(std::lround(std::exp(log_next)));
    if (passed > 0 && log_next >= closing - 1e-6) n = uint32_t(std::ceil(double(passed) / (1.0 + o.tolerance)));
    if ((close_from_below && log_next <= opening) || open_below)
      n = uint32_t(std::floor(double(failed) * (1.0 + o.tolerance)));
    // Strictly inside the bracket.
    if (failed > 0 && n <= failed) n = failed + 1;
    if (passed > 0 && n >= passed) n = passed - 1;
    next = n;
  }
  out.reached = passed > 0;
  if (out.reached) {
    out.count = passed;
    out.ssim = passed_ssim;
  } else {
    const auto best = std::max_element(out.tries.begin(), out.tries.end(),
                                       [](const VisualTry& x, const VisualTry& y) { return x.count < y.count; });
    out.count = best->count;
    out.ssim = best->ssim;
  }
  return out;
}

}  // namespace vpr
