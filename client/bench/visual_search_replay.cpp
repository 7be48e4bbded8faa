// Replays the visual target's search (worker/pipeline/visual_target.*) on
// measured curves, so that a change to the search can be judged on real
// scores without running a back half per try.
//
//   vpremesh-visual-replay [--min-ssim 0.97] [--tolerance 0.02] CURVE...
//
// CURVE: lines "count ssim seconds" (scripts/visual-curve.py), one model. A
// try at a count between two measured ones takes the nearer one's score
// (ties: the lower), the noise between close counts kept as measured; its
// cost is the back half's seconds interpolated in count. Prints, per curve:
// the tries, the count chosen, the smallest measured count that passes with
// every larger measured count within 4% above it passing too (the sweep's
// answer), and the search's cost in back halves at the chosen count.
#include <algorithm>
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
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--min-ssim") && i + 1 < argc) {
      o.min_ssim = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--tolerance") && i + 1 < argc) {
      o.tolerance = std::atof(argv[++i]);
    } else {
      paths.push_back(argv[i]);
    }
  }
  if (paths.empty()) {
    std::fprintf(stderr, "usage: vpremesh-visual-replay [--min-ssim S] [--tolerance T] CURVE...\n");
    return 2;
  }
  std::printf("| curve | tries | chosen | sweep's answer | chosen / answer | cost (back halves at the chosen count) |\n");
  std::printf("|---|---|---:|---:|---:|---:|\n");
  for (const char* path : paths) {
    const std::vector<Point> curve = read_curve(path);
    if (curve.size() < 2) {
      std::fprintf(stderr, "%s: fewer than two points\n", path);
      return 1;
    }
    o.lowest = 100;
    o.highest = curve.back().count;
    double cost = 0;
    auto found = vpr::search_visual_target(o, [&](uint32_t n) -> vpr::StatusOr<double> {
      cost += seconds_at(curve, n);
      return nearest(curve, n).ssim;
    });
    if (!found.ok()) {
      std::fprintf(stderr, "%s: %s\n", path, found.status().to_string().c_str());
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
    std::string tries;
    for (const vpr::VisualTry& t : found->tries) {
      char buf[48];
      std::snprintf(buf, sizeof buf, "%s%u (%.4f)", tries.empty() ? "" : ", ", t.count, t.ssim);
      tries += buf;
    }
    const double one = seconds_at(curve, found->count);
    std::printf("| %s | %s | %u | %u | %.3f | %.2f |\n", path, tries.c_str(), found->count, answer,
                answer ? double(found->count) / answer : 0.0, cost / one);
  }
  return 0;
}
