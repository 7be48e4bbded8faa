// Stage 2 (image-space saliency): each filter against an independent
// reference (brute force or a direct double-precision formula) or against
// shapes whose answer is known in closed form.
#include "saliency/image_saliency.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "saliency/distance_transform.h"
#include "saliency/image_kernels.h"
#include "saliency/inner_feature.h"
#include "saliency/median_filter.h"
#include "saliency/silhouette_feature.h"

namespace vpr {
namespace {

const ExecContext kCpu{};

GrayImage random_gray(int w, int h, unsigned seed, int lo = 0, int hi = 255) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(lo, hi);
  GrayImage img(w, h);
  for (auto& p : img.pixels) p = static_cast<uint8_t>(value(rng));
  return img;
}

Mask random_mask(int w, int h, double density, unsigned seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution on(density);
  Mask m(w, h, 0);
  for (auto& p : m.pixels) p = on(rng) ? 1 : 0;
  return m;
}

// Sets pixel centres (x, y) with inside(x, y) to 1.
template <class Fn>
Mask shape_mask(int w, int h, Fn inside) {
  Mask m(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) m.at(x, y) = inside(x, y) ? 1 : 0;
  return m;
}

bool in_disc(int x, int y, double cx, double cy, double r) {
  return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
}

int count(const Mask& m) {
  int n = 0;
  for (uint8_t p : m.pixels) n += p != 0;
  return n;
}

// Distance from point p to segment ab.
double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
  const double vx = bx - ax, vy = by - ay;
  double t = ((px - ax) * vx + (py - ay) * vy) / (vx * vx + vy * vy);
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(px - (ax + t * vx), py - (ay + t * vy));
}

// Eq. (4) for a shape mask, as detect_features computes it.
FloatImage silhouette_distance_of(const Mask& fg, Mask* silhouette) {
  EXPECT_TRUE(cpu::silhouette_pixels(fg, silhouette, kCpu).ok());
  FloatImage d;
  EXPECT_TRUE(cpu::distance_transform(*silhouette, &d, kCpu).ok());
  for (size_t i = 0; i < d.pixels.size(); ++i)
    if (!fg.pixels[i]) d.pixels[i] = 0.f;
  return d;
}

// ---------------------------------------------------------------- median

TEST(MedianFilter, MatchesBruteForceSortAtEverySizeAndBorder) {
  const int sizes[][2] = {{1, 1}, {2, 3}, {5, 1}, {1, 9}, {7, 7}, {13, 9}, {64, 48}, {100, 5}};
  const int windows[] = {1, 3, 7, 9};
  unsigned seed = 1;
  for (auto [w, h] : sizes) {
    for (int size : windows) {
      // Few gray levels too, so that ties at the median are common.
      // 0: a random blob on a zero background, as in snapshots (exercises the
      // skipped all-zero windows).
      for (int levels : {256, 3, 0}) {
        GrayImage in = random_gray(w, h, seed++, 0, levels ? levels - 1 : 255);
        if (levels == 0) {
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
              if (!in_disc(x, y, w * 0.6, h * 0.4, std::min(w, h) * 0.3)) in.at(x, y) = 0;
        }
        GrayImage out;
        ASSERT_TRUE(cpu::median_filter(in, size, &out, kCpu).ok());
        ASSERT_EQ(out.width, w);
        ASSERT_EQ(out.height, h);
        const int r = size / 2;
        int cpu_mismatch = 0, kernel_mismatch = 0;
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            std::vector<int> window;
            for (int dy = -r; dy <= r; ++dy)
              for (int dx = -r; dx <= r; ++dx)
                window.push_back(in.at(std::clamp(x + dx, 0, w - 1), std::clamp(y + dy, 0, h - 1)));
            std::sort(window.begin(), window.end());
            const int expected = window[window.size() / 2];
            cpu_mismatch += out.at(x, y) != expected;
            kernel_mismatch += median_at(in.pixels.data(), w, h, x, y, r) != expected;
          }
        }
        EXPECT_EQ(cpu_mismatch, 0) << w << "x" << h << " window " << size;
        EXPECT_EQ(kernel_mismatch, 0) << w << "x" << h << " window " << size;
      }
    }
  }
}

TEST(MajorityFilter, EqualsTheMedianOfTheZeroOneImage) {
  const int sizes[][2] = {{1, 1}, {3, 2}, {9, 1}, {40, 30}, {77, 61}};
  unsigned seed = 50;
  for (auto [w, h] : sizes) {
    for (int size : {1, 3, 7}) {
      for (double density : {0.3, 0.5, 0.8}) {
        Mask in = random_mask(w, h, density, seed++);
        for (auto& p : in.pixels) p *= 3;  // any nonzero value counts as set
        GrayImage binary(w, h), median;
        for (size_t i = 0; i < in.pixels.size(); ++i) binary.pixels[i] = in.pixels[i] != 0;
        Mask majority;
        ASSERT_TRUE(cpu::median_filter(binary, size, &median, kCpu).ok());
        ASSERT_TRUE(cpu::majority_filter(in, size, &majority, kCpu).ok());
        EXPECT_EQ(majority.pixels, median.pixels) << w << "x" << h << " window " << size;
        int kernel_mismatch = 0;
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            kernel_mismatch += majority_at(in.pixels.data(), w, h, x, y, size / 2) != median.at(x, y);
        EXPECT_EQ(kernel_mismatch, 0);
      }
    }
  }
}

TEST(MedianFilter, RejectsEvenWindowAndBrokenImage) {
  GrayImage in = random_gray(8, 8, 7), out;
  EXPECT_EQ(cpu::median_filter(in, 4, &out, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::median_filter(in, 0, &out, kCpu).code(), StatusCode::kInvalidArgument);
  in.pixels.pop_back();
  EXPECT_EQ(cpu::median_filter(in, 3, &out, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::median_filter(GrayImage(), 3, &out, kCpu).code(), StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- inner features

TEST(GaussianWeights, SumToTwoToTheSixteenKeepSymmetryAndFollowEq1) {
  for (int n : {1, 3, 5, 11, 21}) {
    for (float sigma : {0.3f, 1.f, 2.f, 5.f}) {
      const std::vector<int> w = gaussian_weights_fixed(n, sigma);
      ASSERT_EQ(w.size(), size_t(n) * n);
      long long sum = 0;
      for (int v : w) sum += v;
      EXPECT_EQ(sum, 65536) << "n " << n << " sigma " << sigma;
      const int r = n / 2;
      double total = 0.0;
      for (int j = -r; j <= r; ++j)
        for (int i = -r; i <= r; ++i) total += std::exp(-(i * i + j * j) / (2.0 * sigma * sigma));
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          const int v = w[j * n + i];
          // The eight symmetries of the square window.
          EXPECT_EQ(v, w[j * n + (n - 1 - i)]);
          EXPECT_EQ(v, w[(n - 1 - j) * n + i]);
          EXPECT_EQ(v, w[i * n + j]);
          EXPECT_GE(v, 0);
          const double ideal =
              65536.0 * std::exp(-((i - r) * (i - r) + (j - r) * (j - r)) / (2.0 * sigma * sigma)) / total;
          // Rounded off-centre; the centre absorbs the rounding error of the others.
          const double tolerance = (i == r && j == r) ? 0.5 * (n * n - 1) : 0.5;
          EXPECT_LE(std::abs(v - ideal), tolerance) << "n " << n << " sigma " << sigma << " at " << i << "," << j;
        }
      }
    }
  }
  // A near-flat window, where rounding to nearest would leave nothing for the centre.
  {
    const std::vector<int> flat = gaussian_weights_fixed(63, 1e4f);
    long long sum = 0;
    for (int v : flat) sum += v;
    EXPECT_EQ(sum, 65536);
    EXPECT_GT(*std::min_element(flat.begin(), flat.end()), 0);
    EXPECT_EQ(flat[0], flat[63 * 63 - 1]);
  }
  // The default window: the centre's share of the rounding error is small in practice.
  const std::vector<int> w = gaussian_weights_fixed(11, 2.f);
  double total = 0.0;
  for (int j = -5; j <= 5; ++j)
    for (int i = -5; i <= 5; ++i) total += std::exp(-(i * i + j * j) / 8.0);
  EXPECT_LE(std::abs(w[5 * 11 + 5] - 65536.0 / total), 4.0);
}

TEST(InnerFeatures, MatchDirectDoubleEvaluationOfEq1To3) {
  const int sizes[][2] = {{4, 3}, {11, 11}, {31, 17}, {96, 80}};
  unsigned seed = 100;
  for (auto [w, h] : sizes) {
    for (auto [n, sigma, c] : {std::tuple{11, 2.f, 3}, std::tuple{5, 1.f, 0}, std::tuple{3, 0.7f, -2}}) {
      const GrayImage gray = random_gray(w, h, seed++);
      const Mask fg = random_mask(w, h, 0.7, seed++);
      Mask features;
      ASSERT_TRUE(cpu::inner_features(gray, fg, n, sigma, c, &features, kCpu).ok());
      // Reference: Eq. (2) as a double-precision weighted mean with the same
      // quantized weights, clamped window written independently of the kernel.
      const std::vector<int> weights = gaussian_weights_fixed(n, sigma);
      int compared = 0, marked = 0, mismatched = 0, kernel_mismatched = 0;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          if (!fg.at(x, y)) {
            EXPECT_EQ(features.at(x, y), 0);
            continue;
          }
          double mean = 0.0;
          for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
              mean += weights[j * n + i] / 65536.0 *
                      gray.at(std::clamp(x + i - n / 2, 0, w - 1), std::clamp(y + j - n / 2, 0, h - 1));
          const double t = mean - c;  // Eq. (3)
          const double p = gray.at(x, y);
          // The per-pixel kernel of the GPU twin, with and without clamping.
          const bool inside = x >= n / 2 && y >= n / 2 && x < w - n / 2 && y < h - n / 2;
          const int64_t kernel_sum = inside ? gaussian_sum_at<false>(gray.pixels.data(), w, h, x, y, weights.data(), n)
                                            : gaussian_sum_at<true>(gray.pixels.data(), w, h, x, y, weights.data(), n);
          kernel_mismatched += inner_feature_test(kernel_sum, gray.at(x, y), c) != (features.at(x, y) != 0);
          if (std::abs(t - p) < 1e-9) continue;
          ++compared;
          marked += t > p;
          mismatched += (t > p) != (features.at(x, y) != 0);
        }
      }
      EXPECT_EQ(mismatched, 0) << w << "x" << h << " n " << n;
      EXPECT_EQ(kernel_mismatched, 0) << w << "x" << h << " n " << n;
      if (w * h >= 100) {
        EXPECT_GT(compared, w * h / 2);
        // Uniform noise: roughly half the pixels are darker than their mean.
        EXPECT_GT(marked, compared / 4);
        EXPECT_LT(marked, compared * 3 / 4);
      }
    }
  }
}

TEST(InnerFeatures, MarkADarkGrooveAndNotAFlatRegion) {
  GrayImage gray(40, 40, 150);
  for (int y = 0; y < 40; ++y) gray.at(20, y) = 120;  // a one-pixel groove, 30 levels darker
  Mask fg(40, 40, 1), features;
  ASSERT_TRUE(cpu::inner_features(gray, fg, 11, 2.f, 3, &features, kCpu).ok());
  for (int y = 0; y < 40; ++y) EXPECT_EQ(features.at(20, y), 1) << y;
  EXPECT_EQ(count(features), 40);  // the flat gray beside it (T = P - 3) is not a feature
  EXPECT_EQ(cpu::inner_features(gray, fg, 10, 2.f, 3, &features, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::inner_features(gray, fg, 11, 0.f, 3, &features, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::inner_features(gray, Mask(39, 40, 1), 11, 2.f, 3, &features, kCpu).code(),
            StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- distance transform

TEST(DistanceTransform, MatchesBruteForce) {
  const int sizes[][2] = {{1, 1}, {1, 17}, {23, 1}, {37, 53}, {130, 70}};
  unsigned seed = 300;
  for (auto [w, h] : sizes) {
    for (double density : {0.002, 0.02, 0.3}) {
      Mask seeds = random_mask(w, h, density, seed++);
      if (count(seeds) == 0) seeds.at(w / 3, h / 2) = 1;
      FloatImage dist;
      ASSERT_TRUE(cpu::distance_transform(seeds, &dist, kCpu).ok());
      std::vector<std::pair<int, int>> sites;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if (seeds.at(x, y)) sites.push_back({x, y});
      double max_error = 0.0;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          long long best = std::numeric_limits<long long>::max();
          for (auto [sx, sy] : sites) best = std::min(best, 1LL * (x - sx) * (x - sx) + 1LL * (y - sy) * (y - sy));
          max_error = std::max(max_error, std::abs(dist.at(x, y) - std::sqrt(double(best))));
        }
      }
      EXPECT_LT(max_error, 1e-4) << w << "x" << h << " density " << density;
    }
  }
}

TEST(DistanceTransform, NoSeedGivesInfinity) {
  FloatImage dist;
  ASSERT_TRUE(cpu::distance_transform(Mask(9, 4, 0), &dist, kCpu).ok());
  for (float d : dist.pixels) EXPECT_EQ(d, std::numeric_limits<float>::infinity());
}

// ---------------------------------------------------------------- skeleton

TEST(Skeleton, RectangleGivesItsMedialAxis) {
  // 200 x 60 rectangle at (20, 20) in a 240 x 100 image. Silhouette pixel
  // centres span x in [20, 219], y in [20, 79]; the medial axis of that
  // rectangle is the centre line y = 49.5 for x in [49.5, 189.5] plus the four
  // corner bisectors.
  const Mask fg = shape_mask(240, 100, [](int x, int y) { return x >= 20 && x < 220 && y >= 20 && y < 80; });
  Mask silhouette, skel;
  const FloatImage d = silhouette_distance_of(fg, &silhouette);
  ASSERT_TRUE(cpu::skeleton(d, fg, 8, &skel, kCpu).ok());

  const double x0 = 20, x1 = 219, y0 = 20, y1 = 79, ym = 49.5, xa = 49.5, xb = 189.5;
  double worst = 0.0;
  for (int y = 0; y < 100; ++y) {
    for (int x = 0; x < 240; ++x) {
      if (!skel.at(x, y)) continue;
      const double dmin = std::min({segment_distance(x, y, xa, ym, xb, ym), segment_distance(x, y, x0, y0, xa, ym),
                                    segment_distance(x, y, x0, y1, xa, ym), segment_distance(x, y, x1, y0, xb, ym),
                                    segment_distance(x, y, x1, y1, xb, ym)});
      worst = std::max(worst, dmin);
    }
  }
  EXPECT_LE(worst, 3.0);
  // Both middle rows (y = 49, 50) are on the two-pixel-wide ridge of D.
  int on_centre_line = 0;
  for (int x = 20 + 30 + 5; x <= 220 - 30 - 5; ++x) on_centre_line += skel.at(x, 49) && skel.at(x, 50);
  EXPECT_EQ(on_centre_line, (220 - 35) - (20 + 35) + 1);
  // And the corner bisectors are found near each corner.
  EXPECT_TRUE(skel.at(30, 30) || skel.at(31, 30) || skel.at(30, 31));
  EXPECT_TRUE(skel.at(209, 69) || skel.at(208, 69) || skel.at(209, 68));
}

TEST(Skeleton, DiscGivesOnlyItsCentre) {
  const Mask fg = shape_mask(200, 200, [](int x, int y) { return in_disc(x, y, 100, 100, 80); });
  Mask silhouette, skel;
  const FloatImage d = silhouette_distance_of(fg, &silhouette);
  ASSERT_TRUE(cpu::skeleton(d, fg, 8, &skel, kCpu).ok());
  EXPECT_GT(count(skel), 0);
  EXPECT_TRUE(skel.at(100, 100));
  double worst = 0.0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x)
      if (skel.at(x, y)) worst = std::max(worst, std::hypot(x - 100.0, y - 100.0));
  EXPECT_LE(worst, 4.0);
}

TEST(Skeleton, RejectsOddLambda) {
  Mask fg(10, 10, 1), skel;
  FloatImage d(10, 10, 1.f);
  EXPECT_EQ(cpu::skeleton(d, fg, 7, &skel, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cpu::skeleton(d, Mask(10, 9, 1), 8, &skel, kCpu).code(), StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------- whole stage

// A flat-shaded disc of radius 120 centred at (256, 200) with a bar ("leg") of
// the given width hanging from its bottom down to y = 480.
Snapshot disc_with_leg(int leg_width) {
  Snapshot s;
  s.coverage = shape_mask(512, 512, [&](int x, int y) {
    const bool leg = x >= 256 - leg_width / 2 && x < 256 - leg_width / 2 + leg_width && y >= 300 && y < 480;
    return in_disc(x, y, 256, 200, 120) || leg;
  });
  s.gray = GrayImage(512, 512, 0);
  s.depth = FloatImage(512, 512, 1.f);
  for (size_t i = 0; i < s.coverage.pixels.size(); ++i) {
    if (s.coverage.pixels[i]) s.gray.pixels[i] = 160, s.depth.pixels[i] = 0.5f;
  }
  return s;
}

TEST(DetectFeatures, LegSilhouetteIsThinDiscSilhouetteIsNot) {
  // 10 px: the leg has a skeleton of its own. 4 px: the thinnest leg that the
  // 7 x 7 majority filter keeps; its distance never reaches 2, so it has no
  // skeleton and is caught by the thin-part rule of thin_features.
  for (int leg_width : {10, 5, 4}) {
    FeatureImages f;
    ASSERT_TRUE(cpu::detect_features(disc_with_leg(leg_width), ImageSaliencyOptions{}, &f, kCpu).ok());
    int leg_pixels = 0, leg_thin = 0, far_pixels = 0, far_thin = 0;
    for (int y = 0; y < 512; ++y) {
      for (int x = 0; x < 512; ++x) {
        if (!f.silhouette.at(x, y)) continue;
        if (y >= 340) {  // on the leg, clear of the disc (its bottom is at y = 320)
          ++leg_pixels;
          leg_thin += f.thin.at(x, y);
        } else if (y < 260) {  // the disc's upper part, > 60 px from the leg
          ++far_pixels;
          far_thin += f.thin.at(x, y);
        }
      }
    }
    EXPECT_GT(leg_pixels, 2 * 130) << "leg width " << leg_width;
    EXPECT_EQ(leg_thin, leg_pixels) << "leg width " << leg_width;
    EXPECT_GT(far_pixels, 400);
    EXPECT_EQ(far_thin, 0) << "leg width " << leg_width;
    // A flat-shaded object has no inner features: the rim sees a darker mean
    // (background 0), the inside a flat one.
    EXPECT_EQ(count(f.inner), 0);
    EXPECT_EQ(count(f.features), count(f.thin));
  }
}

TEST(DetectFeatures, SmallObjectIsThinAllRound) {
  Snapshot s;
  s.coverage = shape_mask(512, 512, [](int x, int y) { return in_disc(x, y, 300, 100, 9); });
  s.gray = GrayImage(512, 512, 0);
  for (size_t i = 0; i < s.gray.pixels.size(); ++i) s.gray.pixels[i] = s.coverage.pixels[i] ? 200 : 0;
  s.depth = FloatImage(512, 512, 1.f);
  FeatureImages f;
  ASSERT_TRUE(cpu::detect_features(s, ImageSaliencyOptions{}, &f, kCpu).ok());
  EXPECT_GT(count(f.silhouette), 40);
  EXPECT_EQ(count(f.thin), count(f.silhouette));
}

// A shaded sphere-like blob with noise, grooves and a leg: every filter has work to do.
Snapshot busy_snapshot(int size) {
  Snapshot s = disc_with_leg(12);
  if (size != 512) {
    s.coverage = shape_mask(size, size, [&](int x, int y) { return in_disc(x, y, size / 2, size / 2, size / 3); });
  }
  s.gray = GrayImage(size, size, 0);
  s.depth = FloatImage(size, size, 1.f);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> noise(-12, 12);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      if (!s.coverage.at(x, y)) continue;
      const double u = (x - size / 2.0) / (size / 2.0), v = (y - size / 2.0) / (size / 2.0);
      double shade = 60 + 150 * std::sqrt(std::max(0.0, 1 - u * u - v * v));
      // Grooves 5 px wide: the 7 x 7 median removes anything 3 px wide or less.
      if ((x + 2 * y) % 37 < 5 || (x * x + y * y) % 4001 < 200) shade -= 40;
      s.gray.at(x, y) = static_cast<uint8_t>(std::clamp(shade + noise(rng), 1.0, 255.0));
      s.depth.at(x, y) = 0.5f;
    }
  }
  return s;
}

TEST(DetectFeatures, IdenticalAtOneAndTwoThreads) {
  const Snapshot s = busy_snapshot(512);
  FeatureImages one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(cpu::detect_features(s, ImageSaliencyOptions{}, &one, kCpu).ok());
  }
  double ms_per_view = 0.0;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    const int runs = 5;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < runs; ++i) ASSERT_TRUE(cpu::detect_features(s, ImageSaliencyOptions{}, &two, kCpu).ok());
    ms_per_view = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / runs;
  }
  std::printf("detect_features: %.1f ms per 512x512 view at 2 threads\n", ms_per_view);
  RecordProperty("detect_features_ms_512", std::to_string(ms_per_view));
  EXPECT_EQ(one.filtered.pixels, two.filtered.pixels);
  EXPECT_EQ(one.foreground.pixels, two.foreground.pixels);
  EXPECT_EQ(one.silhouette.pixels, two.silhouette.pixels);
  EXPECT_EQ(one.inner.pixels, two.inner.pixels);
  EXPECT_EQ(one.silhouette_distance.pixels, two.silhouette_distance.pixels);
  EXPECT_EQ(one.skeleton.pixels, two.skeleton.pixels);
  EXPECT_EQ(one.thin.pixels, two.thin.pixels);
  EXPECT_EQ(one.features.pixels, two.features.pixels);
  // The images are not trivially empty.
  EXPECT_GT(count(one.inner), 1000);
  EXPECT_GT(count(one.skeleton), 50);
  EXPECT_GT(count(one.thin), 100);
}

TEST(DetectFeatures, RejectsMismatchedSnapshotAndBadOptions) {
  Snapshot s = disc_with_leg(10);
  FeatureImages f;
  ImageSaliencyOptions bad;
  bad.median_size = 6;
  EXPECT_EQ(cpu::detect_features(s, bad, &f, kCpu).code(), StatusCode::kInvalidArgument);
  bad = ImageSaliencyOptions{};
  bad.skeleton_lambda = 0;
  EXPECT_EQ(cpu::detect_features(s, bad, &f, kCpu).code(), StatusCode::kInvalidArgument);
  bad = ImageSaliencyOptions{};
  bad.gaussian_sigma = std::nanf("");
  EXPECT_EQ(cpu::detect_features(s, bad, &f, kCpu).code(), StatusCode::kInvalidArgument);
  s.coverage = Mask(511, 512, 1);
  EXPECT_EQ(cpu::detect_features(s, ImageSaliencyOptions{}, &f, kCpu).code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace vpr
