// Replays the visual target's search (worker/pipeline/visual_target.*) on
// measured curves, so that a change to the search can be judged on real
// scores without running a back half per try.
//
//   vpremesh-visual-replay [--min-ssim 0.97] [--tolerance 0.02] [--highest N] [--jitter K] CURVE...
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

}  // namespace

int main(int argc, char** argv) {
  vpr::VisualTargetOptions o;
  std::vector<const char*> paths;
  uint32_t highest = 0;
  int jitter = 0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--min-ssim") && i + 1 < argc) {
      o.min_ssim = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--jitter") && i + 1 < argc) {
      jitter = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--highest") && i + 1 < argc) {
      highest = uint32_t(std::atol(argv[++i]));
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
    std::printf("| curve | sweep's answer | mean cost | most cost | mean tries | most tries | chosen / answer | within 2%% |\n");
    std::printf("|---|---:|---:|---:|---:|---:|---|---:|\n");
  } else {
    std::printf("| curve | tries | chosen | sweep's answer | chosen / answer | cost (back halves at the chosen count) |\n");
    std::printf("|---|---|---:|---:|---:|---:|\n");
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
    std::vector<double> costs, ratios;
    std::vector<size_t> tries_run;
    for (int k = 0; k < std::max(1, jitter); ++k) {
      o.lowest = 100;
      const double scale = jitter > 1 ? 0.9 + 0.2 * k / (jitter - 1) : 1.0;
      o.highest = uint32_t(std::lround(top * scale));
      double cost = 0;
      auto found = vpr::search_visual_target(o, [&](uint32_t n) -> vpr::StatusOr<double> {
        cost += seconds_at(curve, n);
        return nearest(curve, n).ssim;
      });
      if (!found.ok()) {
        std::fprintf(stderr, "%s: %s\n", path, found.status().to_string().c_str());
        return 1;
      }
      costs.push_back(cost / seconds_at(curve, found->count));
      ratios.push_back(answer ? double(found->count) / answer : 0.0);
      tries_run.push_back(found->tries.size());
      if (jitter > 1) continue;
      std::string tries;
      for (const vpr::VisualTry& t : found->tries) {
        char buf[48];
        std::snprintf(buf, sizeof buf, "%s%u (%.4f)", tries.empty() ? "" : ", ", t.count, t.ssim);
        tries += buf;
      }
      std::printf("| %s | %s | %u | %u | %.3f | %.2f |\n", path, tries.c_str(), found->count, answer, ratios[0],
                  costs[0]);
    }
    if (jitter <= 1) continue;
    auto mean = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); };
    size_t within = 0;
    for (double r : ratios) within += r >= 0.98 && r <= 1.02;
    std::printf("| %s | %u | %.2f | %.2f | %.1f | %zu | %.3f to %.3f | %zu of %d |\n", path, answer, mean(costs),
                *std::max_element(costs.begin(), costs.end()),
                std::accumulate(tries_run.begin(), tries_run.end(), 0.0) / tries_run.size(),
                *std::max_element(tries_run.begin(), tries_run.end()), *std::min_element(ratios.begin(), ratios.end()),
                *std::max_element(ratios.begin(), ratios.end()), within, jitter);
  }
  return 0;
}
