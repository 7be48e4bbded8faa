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

VisualSearch::VisualSearch(const VisualTargetOptions& options) : o_(options) {
  // The first try is cheap and low: a back half costs about its count, so
  // trying from below and stepping up by the model spends least.
  next_ = std::clamp(o_.first > 0 ? o_.first : std::max(o_.lowest, o_.highest / 64), o_.lowest, o_.highest);
  width_ = std::log(double(o_.highest)) - std::log(double(o_.lowest)) + 1.0;
  done_ = o_.max_tries <= 0;
}

StatusOr<VisualSearch> VisualSearch::start(const VisualTargetOptions& o) {
  if (!(o.min_ssim > 0 && o.min_ssim < 1)) return invalid_argument("minimum SSIM must be in (0, 1)");
  if (o.lowest < 1 || o.highest < o.lowest) return invalid_argument("the visual target's count range is empty");
  return VisualSearch(o);
}

bool VisualSearch::bracket_closed() const {
  if (passed_ == o_.lowest) return true;   // nothing smaller is allowed
  if (failed_ == o_.highest) return true;  // nothing larger is allowed
  return passed_ > 0 && failed_ > 0 && double(passed_) <= double(failed_) * (1.0 + o_.tolerance);
}

void VisualSearch::record(uint32_t count, double s) {
  if (done_) return;
  const double goal = error_of(o_.min_ssim);
  tries_.push_back({count, s});
  if (short_step_ && s < o_.min_ssim) ++short_steps_failed_;
  short_step_ = false;
  if (s >= o_.min_ssim) {
    if (passed_ == 0 || count < passed_) passed_ = count, passed_ssim_ = s;
  } else if (count > failed_) {
    failed_ = count;
  }
  if (bracket_closed() || int(tries_.size()) >= o_.max_tries) {
    done_ = true;
    return;
  }
  const double lo = failed_ > 0 ? std::log(failed_) : std::log(o_.lowest) - 1e-9;
  const double hi = passed_ > 0 ? std::log(passed_) : std::log(o_.highest) + 1e-9;
  if (passed_ > 0 && failed_ > 0) {
    if (hi - lo < 0.5 * width_) {
      width_ = hi - lo;
      stalled_ = 0;
    } else {
      ++stalled_;
    }
  }

  // The model through the two tries whose errors are nearest the goal.
  std::vector<VisualTry> near = tries_;
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
  if (passed_ == 0 && far) rate = std::min(rate, -1.0);
  // Aim a little past the predicted count, so that the try near the answer
  // passes and one more just inside the tolerance below it can close.
  double log_next = std::log(a.count) + (goal - error_of(a.ssim)) / rate + 0.5 * o_.tolerance;
  // One-sided: at least a factor 2 and at most 16 past the known end;
  // two-sided: the bracket's middle when the model points outside it or
  // has not halved it in two tries. (Bisecting as soon as two tries
  // disagree, a larger count scoring lower, cost most where the bracket's
  // low end was a try far below the bound: on five measured curves,
  // replayed, 5.1 back halves a search on the mean against 4.8 without.)
  if (failed_ == 0) log_next = std::clamp(log_next, hi - std::log(16.0), hi - std::log(2.0));
  // One-sided from below: at least a factor 2 past the highest failure,
  // unless the try nearest the bound lies near it (an error within twice
  // the goal's, and a second try to fit a line through): then the step
  // may be as short as the tolerance, doubled (in log) after each such
  // step that failed, so that noise near the bound cannot make it creep;
  // and the first time, where the model points within the tolerance, the
  // largest count that ends the search if it passes.
  const bool trust_short = b && error_of(a.ssim) <= goal + std::log(2.0);
  const double shortest =
      trust_short ? std::min(std::log1p(o_.tolerance) * std::ldexp(1.0, short_steps_failed_), std::log(2.0))
                  : std::log(2.0);
  bool open_below = false;  // try the largest count that ends the search if it passes
  if (passed_ == 0) {  // then failed_ > 0: every try failed
    open_below = trust_short && short_steps_failed_ == 0 && log_next <= lo + shortest + 1e-9;
    log_next = std::clamp(log_next, lo + shortest, lo + std::log(16.0));
    short_step_ = trust_short && log_next < lo + std::log(2.0) - 1e-9;
  }
  // Close from above: the largest count that would end the search if it
  // fails. Only from a pass near the bound (its error at least 4/5 of the
  // bound's): a pass well above it says the answer lies well below, and a
  // model that points at or past it then fits nothing here (a cliff in the
  // score: a fin on a box scores 0.93 up to 169 vertices and 1.0 from 175;
  // a low-poly table 0.958 at 1,465 and 0.978-0.981 from 1,497 up). Walking
  // down from such a pass by the tolerance took every try the search had;
  // the bracket's middle halves it.
  const double closing = hi - std::log1p(o_.tolerance) + 1e-9;
  const bool pass_near = passed_ > 0 && error_of(passed_ssim_) >= goal - std::log(1.25);
  bool model_past_pass = false;
  if (passed_ > 0 && log_next >= closing) {
    if (pass_near || failed_ == 0)
      log_next = closing;
    else
      model_past_pass = true;
  }
  // Close from below: when the last try failed although the model aimed it
  // past the bound, and the model now points within the tolerance above
  // that failure, try the largest count that ends the search if it
  // passes. Near the bound the score is noisy (SSIM moves by about 0.002
  // between counts 1% apart), and creeping up from the failure by the
  // model's small steps would fail again and again.
  const double opening = lo + std::log1p(o_.tolerance) - 1e-9;
  const bool close_from_below = passed_ > 0 && failed_ > 0 && tries_.back().ssim < o_.min_ssim &&
                                log_next > lo && log_next <= opening;
  // A bracket that has not halved in two tries is bisected, unless the
  // model, fitted near the bound, puts the answer within twice the
  // tolerance below the smallest pass: then the closing try from above.
  // (Passes that walk down from a pass by the tolerance leave the bracket's
  // far low end where it was; its middle would be a try far below the
  // answer that cannot end the search, where the closing try ends it if it
  // fails.)
  const bool model_at_pass =
      pass_near && trust_short && log_next > lo && log_next >= hi - 2 * std::log1p(o_.tolerance);
  if (passed_ > 0 && failed_ > 0 && (stalled_ >= 2 || log_next <= lo || model_past_pass)) {
    if (stalled_ >= 2 && model_at_pass) {
      log_next = closing;
    } else {
      log_next = 0.5 * (lo + hi);
    }
    stalled_ = 0;
  }
  uint32_t n = uint32_t(std::lround(std::exp(log_next)));
  if (passed_ > 0 && log_next >= closing - 1e-6) n = uint32_t(std::ceil(double(passed_) / (1.0 + o_.tolerance)));
  if ((close_from_below && log_next <= opening) || open_below)
    n = uint32_t(std::floor(double(failed_) * (1.0 + o_.tolerance)));
  // Strictly inside the bracket.
  if (failed_ > 0 && n <= failed_) n = failed_ + 1;
  if (passed_ > 0 && n >= passed_) n = passed_ - 1;
  next_ = std::clamp(n, o_.lowest, o_.highest);
}

VisualTargetOutcome VisualSearch::outcome() const {
  VisualTargetOutcome out;
  out.tries = tries_;
  out.reached = passed_ > 0;
  if (out.reached) {
    out.count = passed_;
    out.ssim = passed_ssim_;
  } else if (!tries_.empty()) {
    const auto best = std::max_element(tries_.begin(), tries_.end(),
                                       [](const VisualTry& x, const VisualTry& y) { return x.count < y.count; });
    out.count = best->count;
    out.ssim = best->ssim;
  }
  return out;
}

StatusOr<VisualTargetOutcome> search_visual_target(const VisualTargetOptions& o,
                                                   const std::function<StatusOr<double>(uint32_t)>& score) {
  VPR_ASSIGN_OR_RETURN(VisualSearch search, VisualSearch::start(o));
  for (uint32_t n = search.next(); n != 0; n = search.next()) {
    VPR_ASSIGN_OR_RETURN(const double s, score(n));
    search.record(n, s);
  }
  return search.outcome();
}

}  // namespace vpr
