// Stages 2-3 on the GPU (Section III): every vpr::cuda twin against its CPU
// twin on the same inputs. Masks and distance maps must be identical (the
// filters are integer-exact and the distances are the same correctly rounded
// square roots); points come in the same order, within 1e-6 relative. Skipped
// where no CUDA device can be used.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "cuda_test.h"
#include "gpu/cuda_device.h"
#include "gpu/device_buffer.h"
#include "io/mesh_io.h"
#include "render/views.h"
#include "saliency/distance_transform.h"
#include "saliency/gpu_saliency.h"
#include "saliency/image_saliency.h"
#include "saliency/inner_feature.h"
#include "saliency/median_filter.h"
#include "saliency/silhouette_feature.h"
#include "saliency/unproject.h"

namespace vpr {
namespace {

const ExecContext kCpu{};

class Gpu : public CudaTest {
 protected:
  const ExecContext& ctx_ = gpu_;  // set by CudaTest::SetUp
};

// The sizes every twin is run at: one pixel, thin strips, odd and non-square.
const int kSizes[][2] = {{1, 1}, {2, 3}, {9, 1}, {1, 7}, {33, 17}, {64, 64}, {511, 300}, {300, 511}};

GrayImage random_gray(int w, int h, unsigned seed, int levels = 256) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, levels - 1);
  GrayImage img(w, h);
  for (auto& p : img.pixels) p = static_cast<uint8_t>(value(rng) * (255 / std::max(1, levels - 1)));
  return img;
}

Mask random_mask(int w, int h, double density, unsigned seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution on(density);
  Mask m(w, h, 0);
  for (auto& p : m.pixels) p = on(rng) ? 1 : 0;
  return m;
}

// A disc, a 12 px leg, a 4 px leg, a 2 px hair and a small blob: thick and
// thin parts, some without a skeleton of their own. Scaled to w x h.
Mask shapes(int w, int h) {
  Mask m(w, h, 0);
  const double s = std::min(w, h) / 512.0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double X = x / s, Y = y / s;
      const bool disc = (X - 256) * (X - 256) + (Y - 200) * (Y - 200) <= 120 * 120;
      const bool leg = X >= 200 && X < 212 && Y >= 300 && Y < 480;
      const bool thin_leg = X >= 300 && X < 304 && Y >= 290 && Y < 470;
      const bool hair = std::abs(X - 0.5 * Y - 250) < 1.0 && Y < 80;
      const bool blob = (X - 440) * (X - 440) + (Y - 440) * (Y - 440) <= 64;
      m.at(x, y) = (disc || leg || thin_leg || hair || blob) ? 1 : 0;
    }
  }
  return m;
}

// Shaded, noisy, with grooves, on the shapes' coverage: every filter has work.
Snapshot synthetic_snapshot(int w, int h, unsigned seed) {
  Snapshot s;
  s.coverage = shapes(w, h);
  s.gray = GrayImage(w, h, 0);
  s.depth = FloatImage(w, h, 1.f);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-12, 12);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!s.coverage.at(x, y)) continue;
      double shade = 60 + 150 * std::abs(std::sin(0.013 * x + 0.021 * y));
      if ((x + 2 * y) % 37 < 5) shade -= 40;
      s.gray.at(x, y) = static_cast<uint8_t>(std::clamp(shade + noise(rng), 1.0, 255.0));
      s.depth.at(x, y) = 0.2f + 0.6f * float(x + y) / float(w + h);
    }
  }
  return s;
}

// Bit-for-bit equality, with the first differing pixel in the message.
template <class T>
::testing::AssertionResult same(const Image<T>& gpu, const Image<T>& cpu) {
  if (gpu.width != cpu.width || gpu.height != cpu.height || gpu.pixels.size() != cpu.pixels.size()) {
    return ::testing::AssertionFailure() << "size " << gpu.width << "x" << gpu.height << " vs " << cpu.width << "x"
                                         << cpu.height;
  }
  size_t differ = 0, first = 0;
  for (size_t i = 0; i < cpu.pixels.size(); ++i) {
    if (std::memcmp(&gpu.pixels[i], &cpu.pixels[i], sizeof(T)) != 0 && differ++ == 0) first = i;
  }
  if (differ == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << differ << " of " << cpu.pixels.size() << " pixels differ; first at ("
                                       << first % cpu.width << ", " << first / cpu.width << "): gpu "
                                       << double(gpu.pixels[first]) << ", cpu " << double(cpu.pixels[first]);
}

::testing::AssertionResult same_features(const FeatureImages& g, const FeatureImages& c) {
  const std::pair<const char*, ::testing::AssertionResult> checks[] = {
      {"filtered", same(g.filtered, c.filtered)},
      {"foreground", same(g.foreground, c.foreground)},
      {"silhouette", same(g.silhouette, c.silhouette)},
      {"inner", same(g.inner, c.inner)},
      {"distance", same(g.silhouette_distance, c.silhouette_distance)},
      {"skeleton", same(g.skeleton, c.skeleton)},
      {"thin", same(g.thin, c.thin)},
      {"features", same(g.features, c.features)}};
  for (const auto& [name, result] : checks) {
    if (!result) return ::testing::AssertionFailure() << name << ": " << result.message();
  }
  return ::testing::AssertionSuccess();
}

// Same count and order; each coordinate within 1e-6 of its magnitude (at least 1).
::testing::AssertionResult same_points(const std::vector<float>& gpu, const std::vector<float>& cpu) {
  if (gpu.size() != cpu.size()) return ::testing::AssertionFailure() << gpu.size() << " vs " << cpu.size() << " floats";
  size_t bitwise = 0;
  for (size_t i = 0; i < cpu.size(); ++i) {
    const double tolerance = 1e-6 * std::max(1.0, double(std::abs(cpu[i])));
    if (!(std::abs(double(gpu[i]) - double(cpu[i])) <= tolerance)) {
      return ::testing::AssertionFailure()
             << "point " << i / 3 << " coordinate " << i % 3 << ": gpu " << gpu[i] << ", cpu " << cpu[i];
    }
    bitwise += gpu[i] == cpu[i];
  }
  std::printf("  %zu points, %zu of %zu coordinates bit-identical\n", cpu.size() / 3, bitwise, cpu.size());
  return ::testing::AssertionSuccess();
}

View view_for(int w, int h) {
  Mesh cube;
  for (int i = 0; i < 8; ++i)
    for (int k = 0; k < 3; ++k) cube.positions.push_back(((i >> k) & 1) ? 0.7f : -0.4f);
  cube.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                  2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  auto views = make_views(cube, ViewOptions{});
  EXPECT_TRUE(views.ok());
  View v = views.ok() ? (*views)[1] : View{};
  v.width = w;  // the matrices do not depend on the size: pixel centres map to NDC
  v.height = h;
  return v;
}

// ---------------------------------------------------------------- filters

TEST_F(Gpu, MedianAndMajorityMatchCpu) {
  unsigned seed = 1;
  for (auto [w, h] : kSizes) {
    for (int size : {1, 3, 7, 9}) {
      for (int levels : {256, 3}) {
        const GrayImage in = random_gray(w, h, seed++, levels);
        GrayImage g, c;
        ASSERT_TRUE(cpu::median_filter(in, size, &c, kCpu).ok());
        ASSERT_TRUE(cuda::median_filter(in, size, &g, ctx_).ok());
        EXPECT_TRUE(same(g, c)) << w << "x" << h << " window " << size;
      }
      for (double density : {0.0, 0.3, 0.5, 0.7, 1.0}) {
        Mask in = random_mask(w, h, density, seed++);
        for (auto& p : in.pixels) p *= 255;  // any nonzero is 1
        Mask g, c;
        ASSERT_TRUE(cpu::majority_filter(in, size, &c, kCpu).ok());
        ASSERT_TRUE(cuda::majority_filter(in, size, &g, ctx_).ok());
        EXPECT_TRUE(same(g, c)) << w << "x" << h << " window " << size << " density " << density;
      }
    }
  }
  GrayImage out;
  EXPECT_EQ(cuda::median_filter(GrayImage(4, 4), 4, &out, ctx_).code(), StatusCode::kInvalidArgument);
}

TEST_F(Gpu, InnerFeaturesMatchCpu) {
  unsigned seed = 100;
  for (auto [w, h] : kSizes) {
    const Snapshot s = synthetic_snapshot(w, h, seed++);
    const Mask fg_all(w, h, 1);
    for (int n : {1, 5, 11}) {
      for (int c : {3, -5}) {
        for (const Mask* fg : {&s.coverage, &fg_all}) {
          const GrayImage gray = (fg == &fg_all) ? random_gray(w, h, seed++) : s.gray;
          Mask g, cp;
          ASSERT_TRUE(cpu::inner_features(gray, *fg, n, 2.0f, c, &cp, kCpu).ok());
          ASSERT_TRUE(cuda::inner_features(gray, *fg, n, 2.0f, c, &g, ctx_).ok());
          EXPECT_TRUE(same(g, cp)) << w << "x" << h << " n " << n << " C " << c;
        }
      }
    }
  }
}

TEST_F(Gpu, DistanceTransformIsBitIdentical) {
  unsigned seed = 200;
  for (auto [w, h] : kSizes) {
    std::vector<Mask> seeds = {Mask(w, h, 0), Mask(w, h, 1), random_mask(w, h, 0.002, seed++),
                               random_mask(w, h, 0.3, seed++), shapes(w, h)};
    Mask corner(w, h, 0);
    corner.at(w - 1, 0) = 1;
    seeds.push_back(corner);
    for (const Mask& m : seeds) {
      FloatImage g, c;
      ASSERT_TRUE(cpu::distance_transform(m, &c, kCpu).ok());
      ASSERT_TRUE(cuda::distance_transform(m, &g, ctx_).ok());
      EXPECT_TRUE(same(g, c)) << w << "x" << h;
    }
  }
}

TEST_F(Gpu, SilhouetteSkeletonAndThinFeaturesMatchCpu) {
  for (auto [w, h] : kSizes) {
    for (int variant = 0; variant < 3; ++variant) {
      Mask fg = variant == 0 ? shapes(w, h) : Mask(w, h, variant == 1 ? 1 : 0);
      Mask sil_c, sil_g;
      ASSERT_TRUE(cpu::silhouette_pixels(fg, &sil_c, kCpu).ok());
      ASSERT_TRUE(cuda::silhouette_pixels(fg, &sil_g, ctx_).ok());
      ASSERT_TRUE(same(sil_g, sil_c)) << w << "x" << h;
      FloatImage dist;
      ASSERT_TRUE(cpu::distance_transform(sil_c, &dist, kCpu).ok());
      for (size_t i = 0; i < dist.pixels.size(); ++i)
        if (!fg.pixels[i]) dist.pixels[i] = 0.f;
      for (int lambda : {2, 8, 16}) {
        Mask skel_c, skel_g;
        ASSERT_TRUE(cpu::skeleton(dist, fg, lambda, &skel_c, kCpu).ok());
        ASSERT_TRUE(cuda::skeleton(dist, fg, lambda, &skel_g, ctx_).ok());
        ASSERT_TRUE(same(skel_g, skel_c)) << w << "x" << h << " lambda " << lambda;
        for (float threshold : {0.f, 2.f, 20.f, 150.f}) {
          Mask thin_c, thin_g;
          ASSERT_TRUE(cpu::thin_features(fg, sil_c, skel_c, dist, threshold, &thin_c, kCpu).ok());
          ASSERT_TRUE(cuda::thin_features(fg, sil_c, skel_c, dist, threshold, &thin_g, ctx_).ok());
          EXPECT_TRUE(same(thin_g, thin_c)) << w << "x" << h << " lambda " << lambda << " threshold " << threshold;
        }
      }
    }
  }
}

// ---------------------------------------------------------------- whole stage

TEST_F(Gpu, DetectFeaturesMatchesCpu) {
  unsigned seed = 300;
  for (auto [w, h] : kSizes) {
    std::vector<Snapshot> cases = {synthetic_snapshot(w, h, seed++)};
    Snapshot background{GrayImage(w, h, 0), FloatImage(w, h, 1.f), Mask(w, h, 0)};
    Snapshot full{random_gray(w, h, seed++), FloatImage(w, h, 0.5f), Mask(w, h, 1)};
    cases.push_back(background);
    cases.push_back(full);
    for (const Snapshot& s : cases) {
      FeatureImages g, c;
      ASSERT_TRUE(cpu::detect_features(s, ImageSaliencyOptions{}, &c, kCpu).ok());
      ASSERT_TRUE(cuda::detect_features(s, ImageSaliencyOptions{}, &g, ctx_).ok());
      EXPECT_TRUE(same_features(g, c)) << w << "x" << h;
    }
  }
  FeatureImages out;
  ImageSaliencyOptions odd_lambda;
  odd_lambda.skeleton_lambda = 7;
  EXPECT_EQ(cuda::detect_features(synthetic_snapshot(8, 8, 1), odd_lambda, &out, ctx_).code(),
            StatusCode::kInvalidArgument);
}

TEST_F(Gpu, UnprojectMatchesCpuInRowOrder) {
  unsigned seed = 400;
  for (auto [w, h] : kSizes) {
    const View view = view_for(w, h);
    const Mask features = random_mask(w, h, 0.4, seed++);
    FloatImage depth(w, h);
    std::mt19937 rng(seed++);
    std::uniform_real_distribution<float> z(0.f, 1.f);
    for (auto& d : depth.pixels) d = z(rng) < 0.2f ? 1.f : z(rng);  // a fifth with no surface
    std::vector<float> g = {7.f, 8.f, 9.f}, c = {7.f, 8.f, 9.f};    // both append
    ASSERT_TRUE(cpu::unproject_features(features, depth, view, &c, kCpu).ok());
    ASSERT_TRUE(cuda::unproject_features(features, depth, view, &g, ctx_).ok());
    EXPECT_TRUE(same_points(g, c)) << w << "x" << h;
  }
  std::vector<float> points;
  EXPECT_EQ(cuda::unproject_features(Mask(8, 7), FloatImage(8, 8), view_for(8, 8), &points, ctx_).code(),
            StatusCode::kInvalidArgument);
}

// cpu::detect_features then cpu::unproject_features: what the fused path replaces.
std::vector<float> cpu_view_points(const Snapshot& s, const View& view, FeatureImages* images) {
  std::vector<float> points;
  EXPECT_TRUE(cpu::detect_features(s, ImageSaliencyOptions{}, images, kCpu).ok());
  EXPECT_TRUE(cpu::unproject_features(images->features, s.depth, view, &points, kCpu).ok());
  return points;
}

TEST_F(Gpu, FusedViewPathMatchesCpuFromHostAndDeviceSnapshots) {
  unsigned seed = 500;
  for (auto [w, h] : kSizes) {
    const Snapshot s = synthetic_snapshot(w, h, seed++);
    const View view = view_for(w, h);
    FeatureImages c;
    const std::vector<float> expected = cpu_view_points(s, view, &c);

    std::vector<float> points;
    FeatureImages g;
    ASSERT_TRUE(cuda::view_saliency_points(s, view, ImageSaliencyOptions{}, &points, &g, ctx_).ok());
    EXPECT_TRUE(same_features(g, c)) << w << "x" << h;
    EXPECT_TRUE(same_points(points, expected)) << w << "x" << h;

    // The interop entry point: the same view already on the device.
    const size_t n = s.gray.pixels.size();
    cuda::DeviceBuffer<uint8_t> gray, coverage;
    cuda::DeviceBuffer<float> depth;
    ASSERT_TRUE(gray.upload(s.gray.pixels.data(), n, ctx_).ok());
    ASSERT_TRUE(coverage.upload(s.coverage.pixels.data(), n, ctx_).ok());
    ASSERT_TRUE(depth.upload(s.depth.pixels.data(), n, ctx_).ok());
    const cuda::DeviceSnapshot on_device{w, h, gray.get(), coverage.get(), depth.get()};
    std::vector<float> device_points;
    ASSERT_TRUE(
        cuda::view_saliency_points(on_device, view, ImageSaliencyOptions{}, &device_points, nullptr, ctx_).ok());
    EXPECT_TRUE(same_points(device_points, expected)) << w << "x" << h;
  }
}

TEST_F(Gpu, RenderedHorseViewsMatchCpu) {
  auto mesh = read_mesh("../shared/models/horse.ply");
  if (!mesh.ok()) GTEST_SKIP() << mesh.status().to_string();
  auto renderer = create_renderer(RendererKind::kAuto);
  if (!renderer.ok()) GTEST_SKIP() << renderer.status().to_string();
  auto views = make_views(*mesh, ViewOptions{});
  ASSERT_TRUE(views.ok());
  std::vector<Snapshot> shots;
  ASSERT_TRUE((*renderer)->render(*mesh, *views, &shots).ok());
  std::printf("  renderer: %s\n", (*renderer)->description().c_str());
  std::vector<std::vector<float>> gpu_points(shots.size());
  for (size_t k = 0; k < shots.size(); ++k) {
    FeatureImages c, g;
    const std::vector<float> expected = cpu_view_points(shots[k], (*views)[k], &c);
    ASSERT_TRUE(
        cuda::view_saliency_points(shots[k], (*views)[k], ImageSaliencyOptions{}, &gpu_points[k], &g, ctx_).ok());
    EXPECT_TRUE(same_features(g, c)) << (*views)[k].name;
    EXPECT_TRUE(same_points(gpu_points[k], expected)) << (*views)[k].name;
    EXPECT_GT(expected.size(), 300u) << (*views)[k].name;
  }
  // For the record, not a benchmark: the fused path over all views from host
  // snapshots, warm (uploads included).
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < shots.size(); ++k) {
    std::vector<float> points;
    ASSERT_TRUE(cuda::view_saliency_points(shots[k], (*views)[k], ImageSaliencyOptions{}, &points, nullptr, ctx_).ok());
  }
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("  view_saliency_points: %.2f ms for %zu views of %dx%d\n", ms, shots.size(), shots[0].gray.width,
              shots[0].gray.height);
}

// ---------------------------------------------------------------- errors

TEST_F(Gpu, TinyBudgetIsResourceExhaustedAndReleased) {
  DeviceBudget budget;
  budget.limit = 1024;
  ExecContext tight = ctx_;
  tight.budget = &budget;
  const Snapshot s = synthetic_snapshot(64, 64, 9);
  const View view = view_for(64, 64);
  GrayImage filtered;
  FloatImage dist;
  FeatureImages images;
  std::vector<float> points;
  EXPECT_EQ(cuda::median_filter(s.gray, 7, &filtered, tight).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(cuda::distance_transform(s.coverage, &dist, tight).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(cuda::detect_features(s, ImageSaliencyOptions{}, &images, tight).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(cuda::unproject_features(s.coverage, s.depth, view, &points, tight).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(cuda::view_saliency_points(s, view, ImageSaliencyOptions{}, &points, nullptr, tight).code(),
            StatusCode::kResourceExhausted);
  EXPECT_TRUE(points.empty());
  EXPECT_EQ(budget.used.load(), 0u);  // every buffer given back
  // A budget that holds the feature images (7 masks and a float map, 45 kB)
  // but not the distance transform's scratch: the error comes with kernels
  // already queued, and is still clean.
  const size_t n = s.gray.pixels.size();
  cuda::DeviceBuffer<uint8_t> gray, coverage;
  cuda::DeviceBuffer<float> depth;
  ASSERT_TRUE(gray.upload(s.gray.pixels.data(), n, ctx_).ok());
  ASSERT_TRUE(coverage.upload(s.coverage.pixels.data(), n, ctx_).ok());
  ASSERT_TRUE(depth.upload(s.depth.pixels.data(), n, ctx_).ok());
  const cuda::DeviceSnapshot on_device{64, 64, gray.get(), coverage.get(), depth.get()};
  budget.limit = 50000;
  EXPECT_EQ(cuda::view_saliency_points(on_device, view, ImageSaliencyOptions{}, &points, nullptr, tight).code(),
            StatusCode::kResourceExhausted);
  EXPECT_GT(budget.peak.load(), 45000u);
  EXPECT_EQ(budget.used.load(), 0u);
  EXPECT_TRUE(points.empty());
  // The stream is still usable afterwards.
  GrayImage c;
  ASSERT_TRUE(cpu::median_filter(s.gray, 7, &c, kCpu).ok());
  ASSERT_TRUE(cuda::median_filter(s.gray, 7, &filtered, ctx_).ok());
  EXPECT_TRUE(same(filtered, c));
}

TEST_F(Gpu, ContextWithoutStreamIsRefused) {
  GrayImage out;
  const ExecContext no_stream{Device::kCuda, nullptr, nullptr};
  EXPECT_EQ(cuda::median_filter(GrayImage(4, 4), 3, &out, no_stream).code(), StatusCode::kInternal);
}

}  // namespace
}  // namespace vpr
