// GPU twins of stages 4-6 (Algorithm 1, Eq. 7-18) against their CPU twins on
// the same inputs: k-NN graphs identical (ties on a lattice, duplicated
// points, flat data), front depths identical, sample counts identical and
// sample points equal, AWLOP within 1e-4 of the bounding-box diagonal; a tiny
// device budget is RESOURCE_EXHAUSTED. Skipped where there is no CUDA device.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/rng.h"
#include "cuda_test.h"
#include "gpu/cuda_device.h"
#include "io/mesh_io.h"
#include "resample/adaptive_sampling.h"
#include "resample/awlop.h"
#include "saliency/saliency_field.h"
#include "test_meshes.h"

namespace vpr {
namespace {

const ExecContext kCpu{};

class GeometryGpu : public CudaTest {};

std::vector<float> random_points(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> p(3 * n);
  for (float& x : p) x = u(rng);
  return p;
}

Mesh load_bunny() {
  auto mesh = read_mesh("../shared/models/bunny.obj");
  return mesh.ok() ? std::move(mesh).value() : Mesh{};
}

// Both twins' graphs for the same points, row by row.
void expect_same_graph(const std::vector<float>& p, int k, const ExecContext& gpu, const std::string& what) {
  const size_t n = p.size() / 3;
  std::vector<uint32_t> cpu_graph, gpu_graph;
  ASSERT_TRUE(cpu::knn_graph(p.data(), n, k, &cpu_graph, kCpu).ok());
  const Status s = cuda::knn_graph(p.data(), n, k, &gpu_graph, gpu);
  ASSERT_TRUE(s.ok()) << s.to_string();
  ASSERT_EQ(gpu_graph.size(), cpu_graph.size());
  size_t rows_differing = 0;
  for (size_t i = 0; i < n; ++i)
    rows_differing +=
        !std::equal(cpu_graph.begin() + i * k, cpu_graph.begin() + (i + 1) * k, gpu_graph.begin() + i * k);
  EXPECT_EQ(rows_differing, 0u) << what << ", k = " << k;
}

TEST_F(GeometryGpu, KnnGraphEqualsCpuOnRandomPoints) {
  const std::vector<float> p = random_points(3000, 7);
  for (int k : {1, 10, 20, 64}) expect_same_graph(p, k, gpu_, "random cube");
}

// Integer lattice: most distances tie, so the (distance, index) order decides.
TEST_F(GeometryGpu, KnnGraphTiesOnALatticeEqualCpu) {
  std::vector<float> p;
  for (int z = 0; z < 9; ++z)
    for (int y = 0; y < 9; ++y)
      for (int x = 0; x < 9; ++x) p.insert(p.end(), {float(x), float(y), float(z)});
  for (int k : {1, 5, 6, 7, 18, 19, 26, 30}) expect_same_graph(p, k, gpu_, "9^3 lattice");
}

TEST_F(GeometryGpu, KnnGraphDuplicatesAndDegenerateSetsEqualCpu) {
  const std::vector<float> base = random_points(500, 3);
  std::vector<float> thrice = base;
  thrice.insert(thrice.end(), base.begin(), base.end());
  thrice.insert(thrice.end(), base.begin(), base.end());
  expect_same_graph(thrice, 4, gpu_, "every point three times");
  expect_same_graph(std::vector<float>(3 * 8, 0.5f), 3, gpu_, "eight identical points");
  expect_same_graph(std::vector<float>(3 * 200, -2.0f), 20, gpu_, "200 identical points");
  // Flat (z = 0) and collinear data: the grid must not collapse an axis.
  std::vector<float> flat = random_points(4000, 5), line = random_points(2000, 6);
  for (size_t i = 0; i < flat.size(); i += 3) flat[i + 2] = 0.0f;
  for (size_t i = 0; i < line.size(); i += 3) line[i + 1] = line[i + 2] = 0.25f;
  expect_same_graph(flat, 10, gpu_, "flat");
  expect_same_graph(line, 10, gpu_, "collinear");
  // Two far clusters: most of the grid is empty.
  std::vector<float> far = random_points(1000, 8);
  for (size_t i = 0; i < 1500; ++i) far[i] *= 1e-3f;
  for (size_t i = 1500; i < far.size(); ++i) far[i] = 1000.0f + 1e-3f * far[i];
  expect_same_graph(far, 10, gpu_, "two far clusters");
  // n = k + 1: every other point is a neighbour.
  expect_same_graph(random_points(11, 9), 10, gpu_, "n = k + 1");
}

TEST_F(GeometryGpu, KnnGraphOnBunnyVerticesEqualsCpu) {
  const Mesh bunny = load_bunny();
  if (bunny.positions.empty()) GTEST_SKIP() << "../shared/models/bunny.obj not found";
  expect_same_graph(bunny.positions, 10, gpu_, "bunny vertices");
}

TEST_F(GeometryGpu, KnnGraphRejectsLikeCpu) {
  const std::vector<float> p = random_points(10, 1);
  std::vector<uint32_t> nb;
  EXPECT_EQ(cuda::knn_graph(p.data(), 10, 10, &nb, gpu_).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cuda::knn_graph(p.data(), 10, 0, &nb, gpu_).code(), StatusCode::kInvalidArgument);
  const std::vector<float> many = random_points(100, 2);
  EXPECT_EQ(cuda::knn_graph(many.data(), 100, 65, &nb, gpu_).code(), StatusCode::kUnavailable);
}

TEST_F(GeometryGpu, AdvancingFrontDepthsEqualCpu) {
  std::mt19937 rng(5);
  const size_t n = 20000, open = n - 1000;
  const int k = 3;
  std::uniform_int_distribution<uint32_t> node(0, uint32_t(n - 1)), closed(uint32_t(open), uint32_t(n - 1));
  std::vector<uint32_t> nb(n * k);
  for (size_t i = 0; i < n * k; ++i) nb[i] = i / k < open ? node(rng) : closed(rng);
  std::vector<uint8_t> seed(n, 0);
  for (int s = 0; s < 3; ++s) seed[node(rng) % open] = 1;
  std::vector<int32_t> cpu_depth, gpu_depth;
  ASSERT_TRUE(cpu::advancing_front(nb.data(), n, k, seed.data(), &cpu_depth, kCpu).ok());
  ASSERT_TRUE(cuda::advancing_front(nb.data(), n, k, seed.data(), &gpu_depth, gpu_).ok());
  EXPECT_EQ(gpu_depth, cpu_depth);

  // A chain of 100 nodes: more levels than one batch of launches.
  std::vector<uint32_t> chain(100);
  for (size_t i = 0; i < chain.size(); ++i) chain[i] = uint32_t(i == 0 ? 1 : i - 1);
  std::vector<uint8_t> first(100, 0);
  first[0] = 1;
  ASSERT_TRUE(cuda::advancing_front(chain.data(), 100, 1, first.data(), &gpu_depth, gpu_).ok());
  for (size_t i = 0; i < 100; ++i) EXPECT_EQ(gpu_depth[i], int32_t(i));
  const std::vector<uint32_t> bad = {1, 5};
  EXPECT_EQ(cuda::advancing_front(bad.data(), 2, 1, first.data(), &gpu_depth, gpu_).code(),
            StatusCode::kInvalidArgument);
}

// Saliency points: jittered copies of the vertices in the lowest 40% by y.
std::vector<float> saliency_band(const std::vector<float>& v, size_t count) {
  const size_t nv = v.size() / 3;
  std::vector<size_t> order(nv);
  for (size_t i = 0; i < nv; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return v[3 * a + 1] < v[3 * b + 1]; });
  std::mt19937 rng(2);
  std::uniform_int_distribution<size_t> pick(0, nv * 2 / 5);
  std::normal_distribution<float> jitter(0.0f, 1e-4f);
  std::vector<float> s(3 * count);
  for (size_t i = 0; i < count; ++i) {
    const size_t src = order[pick(rng)];
    for (int a = 0; a < 3; ++a) s[3 * i + a] = v[3 * src + a] + jitter(rng);
  }
  return s;
}

TEST_F(GeometryGpu, SaliencyFieldOnBunnyEqualsCpu) {
  const Mesh bunny = load_bunny();
  if (bunny.positions.empty()) GTEST_SKIP() << "../shared/models/bunny.obj not found";
  const size_t nv = bunny.vertex_count(), ns = 20000;
  const std::vector<float> s = saliency_band(bunny.positions, ns);
  for (float scale : {1.0f, 3.0f}) {
    SaliencyFieldOptions o;
    std::vector<float> cpu_field, gpu_field;
    ASSERT_TRUE(cpu::saliency_field(bunny.positions.data(), nv, s.data(), ns, o, scale, &cpu_field, kCpu).ok());
    ASSERT_TRUE(cuda::saliency_field(bunny.positions.data(), nv, s.data(), ns, o, scale, &gpu_field, gpu_).ok());
    ASSERT_EQ(gpu_field.size(), nv);
    double worst = 0.0;
    for (size_t v = 0; v < nv; ++v) worst = std::max(worst, double(std::abs(gpu_field[v] - cpu_field[v])));
    EXPECT_LT(worst, 1e-6) << "depth scale " << scale;
    EXPECT_GT(*std::max_element(cpu_field.begin(), cpu_field.end()), 0.99f);
    EXPECT_LT(*std::min_element(cpu_field.begin(), cpu_field.end()), 0.5f);  // the front travelled
  }
  // The graph and depths themselves, over the same nodes.
  std::vector<float> nodes = s;
  nodes.insert(nodes.end(), bunny.positions.begin(), bunny.positions.end());
  std::vector<uint32_t> graph;
  ASSERT_TRUE(cuda::knn_graph(nodes.data(), nodes.size() / 3, 10, &graph, gpu_).ok());
  std::vector<uint8_t> seed(nodes.size() / 3, 0);
  std::fill(seed.begin(), seed.begin() + ns, uint8_t(1));
  std::vector<int32_t> cpu_depth, gpu_depth;
  ASSERT_TRUE(cpu::advancing_front(graph.data(), seed.size(), 10, seed.data(), &cpu_depth, kCpu).ok());
  ASSERT_TRUE(cuda::advancing_front(graph.data(), seed.size(), 10, seed.data(), &gpu_depth, gpu_).ok());
  EXPECT_EQ(gpu_depth, cpu_depth);
  std::printf("bunny: max depth %d\n", *std::max_element(cpu_depth.begin(), cpu_depth.end()));

  std::vector<float> field;
  EXPECT_TRUE(cuda::saliency_field(bunny.positions.data(), nv, nullptr, 0, {}, 1.0f, &field, gpu_).ok());
  EXPECT_EQ(field, std::vector<float>(nv, 1.0f));
  SaliencyFieldOptions bad;
  bad.beta = 1.5f;
  EXPECT_EQ(cuda::saliency_field(bunny.positions.data(), nv, s.data(), ns, bad, 1.0f, &field, gpu_).code(),
            StatusCode::kInvalidArgument);
}

// Both samplers over a mesh and importance: quantities, counts and points.
void expect_same_sampling(const Mesh& m, const std::vector<float>& importance, uint32_t target, const ExecContext& gpu,
                          const std::string& what) {
  std::vector<double> cpu_q, gpu_q;
  ASSERT_TRUE(cpu::visual_quantity(m, importance.data(), &cpu_q, kCpu).ok());
  ASSERT_TRUE(cuda::visual_quantity(m, importance.data(), &gpu_q, gpu).ok());
  EXPECT_EQ(gpu_q, cpu_q) << what;  // same double operations, no contraction
  std::vector<uint32_t> cpu_counts, cpu_offsets, gpu_counts, gpu_offsets;
  ASSERT_TRUE(cpu::distribute_counts(cpu_q.data(), cpu_q.size(), target, &cpu_counts, &cpu_offsets, kCpu).ok());
  ASSERT_TRUE(cuda::distribute_counts(cpu_q.data(), cpu_q.size(), target, &gpu_counts, &gpu_offsets, gpu).ok());
  EXPECT_EQ(gpu_counts, cpu_counts) << what;
  EXPECT_EQ(gpu_offsets, cpu_offsets) << what;
  ASSERT_EQ(gpu_offsets.back(), target);
  for (uint32_t seed : {1u, 77u}) {
    SamplingOptions o;
    o.seed = seed;
    std::vector<float> cpu_p, cpu_pi, gpu_p, gpu_pi;
    ASSERT_TRUE(
        cpu::sample_triangles(m, importance.data(), cpu_counts.data(), cpu_offsets.data(), o, &cpu_p, &cpu_pi, kCpu)
            .ok());
    ASSERT_TRUE(
        cuda::sample_triangles(m, importance.data(), cpu_counts.data(), cpu_offsets.data(), o, &gpu_p, &gpu_pi, gpu)
            .ok());
    ASSERT_EQ(gpu_p.size(), cpu_p.size());
    double worst = 0.0, worst_i = 0.0;
    size_t identical = 0;
    for (size_t i = 0; i < cpu_p.size(); ++i) {
      worst = std::max(worst, double(std::abs(gpu_p[i] - cpu_p[i])));
      identical += gpu_p[i] == cpu_p[i];
    }
    for (size_t i = 0; i < cpu_pi.size(); ++i) worst_i = std::max(worst_i, double(std::abs(gpu_pi[i] - cpu_pi[i])));
    EXPECT_LE(worst, 1e-6) << what;
    EXPECT_LE(worst_i, 1e-6) << what;
    std::printf("%s, %u samples, seed %u: %zu of %zu coordinates bit-identical, worst %.3g\n", what.c_str(), target,
                seed, identical, cpu_p.size(), worst);
  }
}

TEST_F(GeometryGpu, SamplingEqualsCpuOnTestShapesAndBunny) {
  const Mesh sphere = testing::icosphere(4);
  std::vector<float> ramp(sphere.vertex_count());
  for (size_t v = 0; v < ramp.size(); ++v) ramp[v] = 0.2f + 0.4f * (sphere.positions[3 * v + 2] + 1.0f);
  expect_same_sampling(sphere, ramp, 20000, gpu_, "icosphere(4)");
  const Mesh soup = testing::flipped_soup(testing::icosphere(3));
  expect_same_sampling(soup, std::vector<float>(soup.vertex_count(), 1.0f), 3001, gpu_, "flipped soup");

  const Mesh bunny = load_bunny();
  if (bunny.positions.empty()) GTEST_SKIP() << "../shared/models/bunny.obj not found";
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.2f, 1.0f);
  std::vector<float> importance(bunny.vertex_count());
  for (float& x : importance) x = u(rng);
  for (uint32_t target : {1u, 5000u, 100000u}) expect_same_sampling(bunny, importance, target, gpu_, "bunny");
}

// Quantities over six decades with zeros: the fixed-point counts agree for
// every target, whatever order each device sums in.
TEST_F(GeometryGpu, DistributeCountsIdenticalOnWideQuantities) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> q(300000);
  for (double& x : q) x = u(rng) < 0.05 ? 0.0 : std::pow(10.0, -6.0 * u(rng)) * u(rng);
  for (uint32_t target : {1u, 7u, 10000u, 99991u, 4000000u}) {
    std::vector<uint32_t> cc, co, gc, go;
    ASSERT_TRUE(cpu::distribute_counts(q.data(), q.size(), target, &cc, &co, kCpu).ok());
    ASSERT_TRUE(cuda::distribute_counts(q.data(), q.size(), target, &gc, &go, gpu_).ok());
    EXPECT_EQ(gc, cc) << "target " << target;
    EXPECT_EQ(go, co) << "target " << target;
  }
  std::vector<uint32_t> c, o;
  const std::vector<double> zeros(5, 0.0);
  EXPECT_EQ(cuda::distribute_counts(zeros.data(), 5, 10, &c, &o, gpu_).code(), StatusCode::kInvalidArgument);
}

// n uniform random points on the unit sphere (clumpy: NN CV ~0.52).
std::vector<float> random_sphere(size_t n, uint64_t seed) {
  std::vector<float> p(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const Philox4 r = random4(seed, i, 0);
    const double z = 2.0 * uniform01(r.v[0]) - 1.0, phi = 2.0 * 3.14159265358979323846 * uniform01(r.v[1]);
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    p[3 * i] = float(s * std::cos(phi));
    p[3 * i + 1] = float(s * std::sin(phi));
    p[3 * i + 2] = float(z);
  }
  return p;
}

double diagonal(const std::vector<float>& p) {
  return bounding_box(p.data(), p.size() / 3).diagonal();
}

// Both AWLOPs from the same start; the GPU result within 1e-4 of the CPU
// result's diagonal, and the statistics alike.
void expect_same_awlop(const std::vector<float>& input, const std::vector<float>& start,
                       const std::vector<float>& importance, double h, const AwlopOptions& o, const ExecContext& gpu,
                       const std::string& what, double min_move = 1e-3) {
  std::vector<float> cpu_x = start, gpu_x = start;
  AwlopStats cpu_stats, gpu_stats;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(cpu::awlop(input.data(), input.size() / 3, cpu_x.data(), importance.data(), start.size() / 3, h, o,
                         &cpu_stats, kCpu)
                  .ok());
  const auto t1 = std::chrono::steady_clock::now();
  const Status s = cuda::awlop(input.data(), input.size() / 3, gpu_x.data(), importance.data(), start.size() / 3, h, o,
                               &gpu_stats, gpu);
  const auto t2 = std::chrono::steady_clock::now();
  ASSERT_TRUE(s.ok()) << s.to_string();
  const double diag = diagonal(cpu_x);
  double worst = 0.0, moved = 0.0;
  for (size_t i = 0; i < start.size() / 3; ++i) {
    const Vec3d c = load3d(cpu_x.data(), i), g = load3d(gpu_x.data(), i), x0 = load3d(start.data(), i);
    worst = std::max(worst, norm(c - g));
    moved = std::max(moved, norm(c - x0));
  }
  EXPECT_LT(worst, 1e-4 * diag) << what;
  EXPECT_GT(moved, min_move * diag) << what << ": the particles should have moved";
  EXPECT_EQ(gpu_stats.iterations, cpu_stats.iterations);
  EXPECT_EQ(gpu_stats.h, cpu_stats.h);
  EXPECT_NEAR(gpu_stats.nn_cv_before, cpu_stats.nn_cv_before, 1e-9) << what;
  EXPECT_NEAR(gpu_stats.nn_cv_after, cpu_stats.nn_cv_after, 1e-3) << what;
  std::printf("%s: worst |gpu - cpu| = %.3g diag; CV %.3f -> %.3f (gpu %.3f); cpu %.1f ms, gpu %.1f ms (first call)\n",
              what.c_str(), worst / diag, cpu_stats.nn_cv_before, cpu_stats.nn_cv_after, gpu_stats.nn_cv_after,
              std::chrono::duration<double, std::milli>(t1 - t0).count(),
              std::chrono::duration<double, std::milli>(t2 - t1).count());
}

TEST_F(GeometryGpu, AwlopOnASphereEqualsCpu) {
  const std::vector<float> input = random_sphere(20000, 1), start = random_sphere(2000, 2);
  std::vector<float> importance(2000);
  for (size_t i = 0; i < importance.size(); ++i) importance[i] = start[3 * i + 2] > 0 ? 1.0f : 0.3f;
  const double h = 2.0 * std::sqrt(4.0 * 3.14159265358979323846 / 2000);
  expect_same_awlop(input, start, importance, h, {}, gpu_, "sphere 2k x 20k");
  AwlopOptions paper;
  paper.support = AwlopSupport::kPaper;
  expect_same_awlop(input, start, importance, 0.02, paper, gpu_, "sphere, small h", 0.0);
}

// The lead's size: 10k particles, 80k input points, 10 iterations, on bunny.
TEST_F(GeometryGpu, AwlopOnBunnyEqualsCpu) {
  const Mesh bunny = load_bunny();
  if (bunny.positions.empty()) GTEST_SKIP() << "../shared/models/bunny.obj not found";
  const std::vector<float> ones(bunny.vertex_count(), 1.0f);
  auto samples = [&](uint32_t count, uint64_t seed, std::vector<float>* pi) {
    std::vector<double> q;
    std::vector<uint32_t> counts, offsets;
    std::vector<float> p;
    EXPECT_TRUE(cpu::visual_quantity(bunny, ones.data(), &q, kCpu).ok());
    EXPECT_TRUE(cpu::distribute_counts(q.data(), q.size(), count, &counts, &offsets, kCpu).ok());
    SamplingOptions o;
    o.seed = seed;
    EXPECT_TRUE(cpu::sample_triangles(bunny, ones.data(), counts.data(), offsets.data(), o, &p, pi, kCpu).ok());
    return p;
  };
  std::vector<float> unused, importance;
  const std::vector<float> input = samples(80000, 1, &unused), start = samples(10000, 2, &importance);
  const Aabb box = bounding_box(bunny);
  for (size_t i = 0; i < importance.size(); ++i)
    importance[i] = 0.2f + 0.8f * (start[3 * i + 1] - box.lo[1]) / (box.hi[1] - box.lo[1]);
  auto h = awlop_support_radius(AwlopSupport::kTargetSpacing, 2.0f, 0.0, total_area(bunny), 10000);
  ASSERT_TRUE(h.ok());
  expect_same_awlop(input, start, importance, *h, {}, gpu_, "bunny 10k x 80k");
  // Warm: the timing the lead's target refers to.
  std::vector<float> x = start;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(cuda::awlop(input.data(), 80000, x.data(), importance.data(), 10000, *h, {}, nullptr, gpu_).ok());
  std::printf("bunny 10k x 80k x 10 iterations, warm: %.2f ms\n",
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

TEST_F(GeometryGpu, TinyBudgetIsResourceExhausted) {
  DeviceBudget budget;
  budget.limit = 1024;
  ExecContext tight = gpu_;
  tight.budget = &budget;
  const std::vector<float> p = random_points(2000, 4);
  std::vector<uint32_t> nb;
  EXPECT_EQ(cuda::knn_graph(p.data(), 2000, 10, &nb, tight).code(), StatusCode::kResourceExhausted);
  std::vector<float> field;
  EXPECT_EQ(cuda::saliency_field(p.data() + 300, 1900, p.data(), 100, {}, 1.0f, &field, tight).code(),
            StatusCode::kResourceExhausted);
  const Mesh sphere = testing::icosphere(3);
  const std::vector<float> ones(sphere.vertex_count(), 1.0f);
  std::vector<double> q;
  EXPECT_EQ(cuda::visual_quantity(sphere, ones.data(), &q, tight).code(), StatusCode::kResourceExhausted);
  ASSERT_TRUE(cpu::visual_quantity(sphere, ones.data(), &q, kCpu).ok());
  std::vector<uint32_t> counts, offsets;
  EXPECT_EQ(cuda::distribute_counts(q.data(), q.size(), 5000, &counts, &offsets, tight).code(),
            StatusCode::kResourceExhausted);
  ASSERT_TRUE(cpu::distribute_counts(q.data(), q.size(), 5000, &counts, &offsets, kCpu).ok());
  std::vector<float> pts, pi;
  EXPECT_EQ(cuda::sample_triangles(sphere, ones.data(), counts.data(), offsets.data(), {}, &pts, &pi, tight).code(),
            StatusCode::kResourceExhausted);
  std::vector<float> x(p.begin(), p.begin() + 300);
  const std::vector<float> imp(100, 1.0f);
  EXPECT_EQ(cuda::awlop(p.data(), 2000, x.data(), imp.data(), 100, 0.1, {}, nullptr, tight).code(),
            StatusCode::kResourceExhausted);
  EXPECT_EQ(budget.used.load(), 0u);  // everything charged was given back
  // The same calls go through with room.
  EXPECT_TRUE(cuda::knn_graph(p.data(), 2000, 10, &nb, gpu_).ok());
}

}  // namespace
}  // namespace vpr
