// Replays the visual target's search (worker/pipeline/visual_target.*) on
// measured curves, so that a change to the search can be judged on real
// scores without running a back half per try.
//
//   vpremesh-visual-replay [--min-ssim 0.97] [--tolerance 0.02] [--highest N] [--jitter K]
//                          [--ahead none|pass|both] [--fail-guess D] CURVE...
//
// CURVE: lines "count ssim seconds" (scripts/visual-curve.py), one model. A
// try at a count between two measured ones takes the nearer one's score
// (ties: the lower), the noise between close counts kept as measured; its
// cost is the back half's seconds interpolated in count. Prints, per curve:
// the tries, the count chosen, the smallest measured count that passes with
// every larger measured count within 4% above it passing too (the sweep's
// answer), and the search's cost in back halves at the chosen count.
// --highest: the search's top (the input's vertex count), when the curve's
// largest count is not it. --jitter K: K searches with tops spread over 0.9
// to 1.1 times it, summarized (mean and most cost and tries, the range of
// chosen / answer, how many land within 2% of the answer).
// --ahead: tries made ahead, as the pipeline makes them (pipeline.cpp,
// run_visual_target): while the try at n runs, the search's next try if n
// passes ("pass"), and also its next if n fails with a score D below the
// bound ("both", D = --fail-guess, 0.0005 by default) run beside it. The
// cost is then wall time with tries side by side costing no more than
// alone (a bound: on 16 cores a back half leaves most cores idle, measured
// in docs/benchmarks.md), and "work" adds every try started, the cancelled
// ones for the time they ran; "hits": tries taken from those made ahead.
#include <algorithm>
#include <numeric>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <map>

#include "pipeline/visual_target.h"

namespace {

struct Point {
  uint32_t count;
  double ssim, seconds;
};

std::vector<Point> read_curve(const char* path) {
  std::ifstream in(path);
  std::vector<Point> out;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    Point p{};
    if (s >> p.count >> p.ssim >> p.seconds) out.push_back(p);
  }
  std::sort(out.begin(), out.end(), [](const Point& a, const Point& b) { return a.count < b.count; });
  return out;
}

const Point& nearest(const std::vector<Point>& curve, uint32_t n) {
  auto it = std::lower_bound(curve.begin(), curve.end(), n, [](const Point& p, uint32_t v) { return p.count < v; });
  if (it == curve.end()) return curve.back();
  if (it == curve.begin() || it->count == n) return *it;
  const Point& below = *(it - 1);
  return (n - below.count <= it->count - n) ? below : *it;
}

double seconds_at(const std::vector<Point>& curve, uint32_t n) {
  auto it = std::lower_bound(curve.begin(), curve.end(), n, [](const Point& p, uint32_t v) { return p.count < v; });
  if (it == curve.end()) return curve.back().seconds * n / curve.back().count;
  if (it == curve.begin()) return it->seconds * n / it->count;
  const Point& a = *(it - 1);
  const double t = double(n - a.count) / double(it->count - a.count);
  return a.seconds + t * (it->seconds - a.seconds);
}

enum class Ahead { kNone, kPass, kBoth };

struct Replayed {
  vpr::VisualTargetOutcome outcome;
  double wall = 0, work = 0;  // seconds
  int hits = 0;
};

// One search on a curve, with tries made ahead as `ahead` says.
vpr::StatusOr<Replayed> replay(const vpr::VisualTargetOptions& o, const std::vector<Point>& curve, Ahead ahead,
                               double fail_guess) {
  VPR_ASSIGN_OR_RETURN(vpr::VisualSearch search, vpr::VisualSearch::start(o));
  struct Made {
    double start, seconds;
  };
  std::map<uint32_t, Made> made;
  Replayed r;
  double t = 0;
  for (uint32_t n = search.next(); n != 0; n = search.next()) {
    if (ahead != Ahead::kNone) {
      std::vector<uint32_t> branches = {search.next_after(n, std::min(o.min_ssim + 1e-4, 1.0))};
      if (ahead == Ahead::kBoth) branches.push_back(search.next_after(n, o.min_ssim - fail_guess));
      for (uint32_t b : branches)
        if (b != 0 && b != n && !made.count(b)) made[b] = {t, seconds_at(curve, b)};
    }
    double finish;
    if (auto it = made.find(n); it != made.end()) {
      finish = std::max(t, it->second.start + it->second.seconds);
      r.work += it->second.seconds;
      ++r.hits;
      made.erase(it);
    } else {
      finish = t + seconds_at(curve, n);
      r.work += seconds_at(curve, n);
    }
    t = finish;
    search.record(n, nearest(curve, n).ssim);
    // Only the search's next try is kept; the others stop (their time so far is spent).
    for (auto it = made.begin(); it != made.end();) {
      if (it->first == search.next()) {
        ++it;
        continue;
      }
      r.work += std::min(t - it->second.start, it->second.seconds);
      it = made.erase(it);
    }
  }
  r.wall = t;
  r.outcome = search.outcome();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  vpr::VisualTargetOptions o;
  std::vector<const char*> paths;
  uint32_t highest = 0;
  int jitter = 0;
  Ahead ahead = Ahead::kNone;
  double fail_guess = 0.0005;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--min-ssim") && i + 1 < argc) {
      o.min_ssim = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--jitter") && i + 1 < argc) {
      jitter = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--highest") && i + 1 < argc) {
      highest = uint32_t(std::atol(argv[++i]));
    } else if (!std::strcmp(argv[i], "--ahead") && i + 1 < argc) {
      const std::string mode = argv[++i];
      ahead = mode == "both" ? Ahead::kBoth : mode == "pass" ? Ahead::kPass : Ahead::kNone;
    } else if (!std::strcmp(argv[i], "--fail-guess") && i + 1 < argc) {
      fail_guess = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--tolerance") && i + 1 < argc) {
      o.tolerance = std::atof(argv[++i]);
    } else {
      paths.push_back(argv[i]);
    }
  }
  if (paths.empty()) {
    std::fprintf(stderr, "usage: vpremesh-visual-replay [--min-ssim S] [--tolerance T] [--highest N] [--jitter K] CURVE...\n");
    return 2;
  }
  if (jitter > 1) {
    std::printf("| curve | sweep's answer | mean cost | most cost | mean tries | most tries | chosen / answer | within 2%% |%s\n",
                ahead != Ahead::kNone ? " mean work | mean hits |" : "");
    std::printf("|---|---:|---:|---:|---:|---:|---|---:|%s\n", ahead != Ahead::kNone ? "---:|---:|" : "");
  } else {
    std::printf("| curve | tries | chosen | sweep's answer | chosen / answer | cost (back halves at the chosen count) |%s\n",
                ahead != Ahead::kNone ? " work | hits |" : "");
    std::printf("|---|---|---:|---:|---:|---:|%s\n", ahead != Ahead::kNone ? "---:|---:|" : "");
  }
  for (const char* path : paths) {
    const std::vector<Point> curve = read_curve(path);
    if (curve.size() < 2) {
      std::fprintf(stderr, "%s: fewer than two points\n", path);
      return 1;
    }
    // The sweep's answer: the smallest measured count passing, with every
    // measured count up to 4% above it passing too (an isolated pass in
    // the noise is not a count a search can be asked to find).
    uint32_t answer = 0;
    for (size_t i = 0; i < curve.size() && !answer; ++i) {
      if (curve[i].ssim < o.min_ssim) continue;
      bool holds = true;
      for (size_t j = i + 1; j < curve.size() && curve[j].count <= 1.04 * curve[i].count; ++j)
        holds &= curve[j].ssim >= o.min_ssim;
      if (holds) answer = curve[i].count;
    }
    const uint32_t top = highest ? highest : curve.back().count;
    // One search per top: the given one, or with --jitter K, K tops spread
    // evenly over 0.9 to 1.1 times it (each top moves every try to other
    // counts, so each run meets the measured noise at other places).
    std::vector<double> costs, ratios, works, hits;
    std::vector<size_t> tries_run;
    for (int k = 0; k < std::max(1, jitter); ++k) {
      o.lowest = 100;
      const double scale = jitter > 1 ? 0.9 + 0.2 * k / (jitter - 1) : 1.0;
      o.highest = uint32_t(std::lround(top * scale));
      auto replayed = replay(o, curve, ahead, fail_guess);
      if (!replayed.ok()) {
        std::fprintf(stderr, "%s: %s\n", path, replayed.status().to_string().c_str());
        return 1;
      }
      const vpr::VisualTargetOutcome* found = &replayed->outcome;
      const double at_count = seconds_at(curve, found->count);
      costs.push_back(replayed->wall / at_count);
      works.push_back(replayed->work / at_count);
      hits.push_back(replayed->hits);
      ratios.push_back(answer ? double(found->count) / answer : 0.0);
      tries_run.push_back(found->tries.size());
      if (jitter > 1) continue;
      std::string tries;
      for (const vpr::VisualTry& t : found->tries) {
        char buf[48];
        std::snprintf(buf, sizeof buf, "%s%u (%.4f)", tries.empty() ? "" : ", ", t.count, t.ssim);
        tries += buf;
      }
      std::printf("| %s | %s | %u | %u | %.3f | %.2f |", path, tries.c_str(), found->count, answer, ratios[0],
                  costs[0]);
      if (ahead != Ahead::kNone) std::printf(" %.2f | %d |", works[0], int(hits[0]));
      std::printf("\n");
    }
    if (jitter <= 1) continue;
    auto mean = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); };
    size_t within = 0;
    for (double r : ratios) within += r >= 0.98 && r <= 1.02;
    std::printf("| %s | %u | %.2f | %.2f | %.1f | %zu | %.3f to %.3f | %zu of %d |", path, answer, mean(costs),
                *std::max_element(costs.begin(), costs.end()),
                std::accumulate(tries_run.begin(), tries_run.end(), 0.0) / tries_run.size(),
                *std::max_element(tries_run.begin(), tries_run.end()), *std::min_element(ratios.begin(), ratios.end()),
                *std::max_element(ratios.begin(), ratios.end()), within, jitter);
    if (ahead != Ahead::kNone) std::printf(" %.2f | %.1f |", mean(works), mean(hits));
    std::printf("\n");
  }
  return 0;
}
