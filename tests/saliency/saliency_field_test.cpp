// Stage 4 (Algorithm 1): the k-NN graph against brute force, the advancing
// front against BFS, and the importance field against beta^(d - 1) on shapes
// whose depths are known by hand.
#include "saliency/saliency_field.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace vpr {
namespace {

const ExecContext kCpu{};

// Brute force, with the squared distance summed in float in the same order as
// FLANN's L2_Simple so that ties are ties in both.
std::vector<uint32_t> brute_knn(const std::vector<float>& p, int k) {
  const size_t n = p.size() / 3;
  std::vector<uint32_t> out(n * k);
  std::vector<std::pair<float, uint32_t>> row;
  for (size_t i = 0; i < n; ++i) {
    row.clear();
    for (size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      float d = 0.0f;
      for (int a = 0; a < 3; ++a) {
        const float diff = p[3 * i + a] - p[3 * j + a];
        d += diff * diff;
      }
      row.push_back({d, uint32_t(j)});
    }
    std::partial_sort(row.begin(), row.begin() + k, row.end());
    for (int j = 0; j < k; ++j) out[i * k + j] = row[j].second;
  }
  return out;
}

std::vector<float> random_points(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> p(3 * n);
  for (float& x : p) x = u(rng);
  return p;
}

TEST(KnnGraph, MatchesBruteForceOnRandomPoints) {
  const std::vector<float> p = random_points(3000, 7);
  for (int k : {1, 10, 20}) {
    std::vector<uint32_t> nb;
    ASSERT_TRUE(cpu::knn_graph(p.data(), 3000, k, &nb, kCpu).ok());
    const std::vector<uint32_t> expected = brute_knn(p, k);
    // Row order too: nearest first, ties by index.
    EXPECT_EQ(nb, expected) << "k = " << k;
  }
}

// An integer grid: every distance is exact in float and most are tied, so the
// (distance, index) order at the k-th place is what is being tested.
TEST(KnnGraph, TiesOnAGridAreBrokenBySmallerIndex) {
  std::vector<float> p;
  for (int z = 0; z < 9; ++z)
    for (int y = 0; y < 9; ++y)
      for (int x = 0; x < 9; ++x) p.insert(p.end(), {float(x), float(y), float(z)});
  for (int k : {1, 5, 6, 7, 18, 19, 26, 30}) {
    std::vector<uint32_t> nb;
    ASSERT_TRUE(cpu::knn_graph(p.data(), p.size() / 3, k, &nb, kCpu).ok());
    EXPECT_EQ(nb, brute_knn(p, k)) << "k = " << k;
  }
}

// Every point three times: the two copies at distance 0 are the first two
// neighbours (smaller index first), the query itself never is.
TEST(KnnGraph, DuplicatesAreNeighboursButSelfIsNot) {
  const std::vector<float> base = random_points(500, 3);
  std::vector<float> p = base;
  p.insert(p.end(), base.begin(), base.end());
  p.insert(p.end(), base.begin(), base.end());
  const size_t n = p.size() / 3;
  std::vector<uint32_t> nb;
  ASSERT_TRUE(cpu::knn_graph(p.data(), n, 4, &nb, kCpu).ok());
  EXPECT_EQ(nb, brute_knn(p, 4));
  for (size_t i = 0; i < n; ++i) {
    const uint32_t b = uint32_t(i % 500);
    std::vector<uint32_t> copies;
    for (uint32_t c : {b, b + 500, b + 1000})
      if (c != i) copies.push_back(c);
    EXPECT_EQ(nb[4 * i], copies[0]);
    EXPECT_EQ(nb[4 * i + 1], copies[1]);
  }
  // Eight copies of one point and k = 3: the self index is dropped even when
  // more than k + 1 points tie at distance 0.
  std::vector<float> same(3 * 8, 0.5f);
  ASSERT_TRUE(cpu::knn_graph(same.data(), 8, 3, &nb, kCpu).ok());
  EXPECT_EQ(std::vector<uint32_t>(nb.begin(), nb.begin() + 3), (std::vector<uint32_t>{1, 2, 3}));
  EXPECT_EQ(std::vector<uint32_t>(nb.begin() + 3 * 5, nb.begin() + 3 * 6), (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(std::vector<uint32_t>(nb.begin() + 3 * 2, nb.begin() + 3 * 3), (std::vector<uint32_t>{0, 1, 3}));
}

TEST(KnnGraph, IndependentOfThreadCount) {
  const std::vector<float> p = random_points(20000, 11);
  std::vector<uint32_t> one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(cpu::knn_graph(p.data(), 20000, 10, &one, kCpu).ok());
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    ASSERT_TRUE(cpu::knn_graph(p.data(), 20000, 10, &two, kCpu).ok());
  }
  EXPECT_EQ(one, two);
}

TEST(KnnGraph, TooFewPointsIsInvalidArgumentNamingNAndK) {
  const std::vector<float> p = random_points(10, 1);
  std::vector<uint32_t> nb;
  const Status s = cpu::knn_graph(p.data(), 10, 10, &nb, kCpu);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("10 points"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("k = 10"), std::string::npos) << s.message();
  EXPECT_EQ(cpu::knn_graph(p.data(), 10, 0, &nb, kCpu).code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(cpu::knn_graph(p.data(), 10, 9, &nb, kCpu).ok());
}

// Plain BFS on the directed graph j -> i iff j is in N(i).
std::vector<int32_t> bfs(const std::vector<uint32_t>& nb, int k, const std::vector<uint8_t>& seed) {
  const size_t n = seed.size();
  std::vector<std::vector<uint32_t>> out(n);
  for (size_t i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) out[nb[i * k + j]].push_back(uint32_t(i));
  std::vector<int32_t> d(n, -1);
  std::deque<uint32_t> q;
  for (size_t i = 0; i < n; ++i)
    if (seed[i]) d[i] = 0, q.push_back(uint32_t(i));
  while (!q.empty()) {
    const uint32_t u = q.front();
    q.pop_front();
    for (uint32_t v : out[u])
      if (d[v] < 0) d[v] = d[u] + 1, q.push_back(v);
  }
  return d;
}

TEST(AdvancingFront, ChainGivesHopCountAndDirectionMatters) {
  // N(i) = {i - 1}: edges run forward only, so from seed 0 depth = i; from a
  // seed at the far end nothing else is reachable.
  const size_t n = 50;
  std::vector<uint32_t> nb(n);
  for (size_t i = 0; i < n; ++i) nb[i] = uint32_t(i == 0 ? 1 : i - 1);
  std::vector<uint8_t> seed(n, 0);
  seed[0] = 1;
  std::vector<int32_t> d;
  ASSERT_TRUE(cpu::advancing_front(nb.data(), n, 1, seed.data(), &d, kCpu).ok());
  for (size_t i = 0; i < n; ++i) EXPECT_EQ(d[i], int32_t(i));
  seed.assign(n, 0);
  seed[n - 1] = 1;
  ASSERT_TRUE(cpu::advancing_front(nb.data(), n, 1, seed.data(), &d, kCpu).ok());
  for (size_t i = 0; i + 1 < n; ++i) EXPECT_EQ(d[i], -1);
  EXPECT_EQ(d[n - 1], 0);
}

TEST(AdvancingFront, GridWithDisconnectedPartMatchesBfs) {
  // A 30 x 30 4-connected grid (boundary rows repeat a neighbour to fill k = 4)
  // plus a separate 5-node ring that no seed reaches.
  const int w = 30, k = 4;
  const size_t grid = size_t(w) * w, n = grid + 5;
  std::vector<uint32_t> nb;
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) {
      std::vector<uint32_t> r;
      if (x > 0) r.push_back(y * w + x - 1);
      if (x + 1 < w) r.push_back(y * w + x + 1);
      if (y > 0) r.push_back((y - 1) * w + x);
      if (y + 1 < w) r.push_back((y + 1) * w + x);
      while (r.size() < 4) r.push_back(r[0]);
      nb.insert(nb.end(), r.begin(), r.end());
    }
  for (uint32_t i = 0; i < 5; ++i) {
    const uint32_t a = uint32_t(grid) + (i + 1) % 5, b = uint32_t(grid) + (i + 4) % 5;
    nb.insert(nb.end(), {a, b, a, b});
  }
  std::vector<uint8_t> seed(n, 0);
  seed[0] = 1;            // corner
  seed[15 * w + 20] = 1;  // interior
  std::vector<int32_t> d;
  ASSERT_TRUE(cpu::advancing_front(nb.data(), n, k, seed.data(), &d, kCpu).ok());
  EXPECT_EQ(d, bfs(nb, k, seed));
  // Manhattan distance to the nearer seed, by hand.
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) ASSERT_EQ(d[y * w + x], std::min(x + y, std::abs(x - 20) + std::abs(y - 15)));
  for (size_t i = grid; i < n; ++i) EXPECT_EQ(d[i], -1);
}

TEST(AdvancingFront, RandomDirectedGraphsMatchBfsAtAnyThreadCount) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const size_t n = 20000;
    const int k = 3;
    // The last 1000 nodes list only each other: a closed part no seed reaches.
    const size_t open = n - 1000;
    std::uniform_int_distribution<uint32_t> node(0, uint32_t(n - 1)), closed(uint32_t(open), uint32_t(n - 1));
    std::vector<uint32_t> nb(n * k);
    for (size_t i = 0; i < n * k; ++i) nb[i] = i / k < open ? node(rng) : closed(rng);
    std::vector<uint8_t> seed(n, 0);
    for (int s = 0; s < 3; ++s) seed[node(rng) % open] = 1;
    std::vector<int32_t> one, two;
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      ASSERT_TRUE(cpu::advancing_front(nb.data(), n, k, seed.data(), &one, kCpu).ok());
    }
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
      ASSERT_TRUE(cpu::advancing_front(nb.data(), n, k, seed.data(), &two, kCpu).ok());
    }
    const std::vector<int32_t> expected = bfs(nb, k, seed);
    EXPECT_EQ(one, expected);
    EXPECT_EQ(two, expected);
    EXPECT_GE(std::count(expected.begin(), expected.end(), -1), 1000);
    for (size_t i = open; i < n; ++i) ASSERT_EQ(expected[i], -1);
    EXPECT_GT(*std::max_element(expected.begin(), expected.end()), 5);  // several front steps
  }
}

TEST(AdvancingFront, RejectsOutOfRangeNeighbour) {
  std::vector<uint32_t> nb = {1, 5};
  std::vector<uint8_t> seed = {1, 0};
  std::vector<int32_t> d;
  EXPECT_EQ(cpu::advancing_front(nb.data(), 2, 1, seed.data(), &d, kCpu).code(), StatusCode::kInvalidArgument);
}

// Vertices on a line at x = 1..N, one saliency point at x = 0. With k = 2 the
// neighbours of x = i are i - 1 and i + 1, so vertex i has depth i.
std::vector<float> line(int count) {
  std::vector<float> v;
  for (int i = 1; i <= count; ++i) v.insert(v.end(), {float(i), 0.0f, 0.0f});
  return v;
}

TEST(SaliencyField, DecaysAsBetaToTheDepthMinusOneOnALine) {
  const int count = 12;
  const std::vector<float> v = line(count);
  const float seed[3] = {0.0f, 0.0f, 0.0f};
  SaliencyFieldOptions o;
  o.k = 2;
  o.beta = 0.7f;
  o.min_importance = 0.2f;
  std::vector<float> imp;
  ASSERT_TRUE(cpu::saliency_field(v.data(), count, seed, 1, o, 1.0f, &imp, kCpu).ok());
  ASSERT_EQ(imp.size(), size_t(count));
  EXPECT_EQ(imp[0], 1.0f);  // one hop from the saliency point
  for (int i = 1; i <= count; ++i) {
    const double expected = std::max(0.2, std::pow(0.7, i - 1));
    EXPECT_NEAR(imp[i - 1], expected, 1e-6) << "vertex at depth " << i;
  }
  // 0.7^4 = 0.2401 is above the floor, 0.7^5 = 0.168 is not.
  EXPECT_NEAR(imp[4], 0.2401f, 1e-6);
  EXPECT_EQ(imp[5], 0.2f);
  for (int i = 1; i < count; ++i) EXPECT_LE(imp[i], imp[i - 1]);

  ASSERT_TRUE(cpu::saliency_field(v.data(), count, seed, 1, o, 2.0f, &imp, kCpu).ok());
  for (int i = 1; i <= count; ++i)
    EXPECT_NEAR(imp[i - 1], std::max(0.2, std::pow(0.7, (i - 1) / 2.0)), 1e-6) << "depth " << i;
  EXPECT_NEAR(imp[1], std::sqrt(0.7), 1e-6);
}

TEST(SaliencyField, NoSaliencyPointsIsUniformAndUnreachableGetsTheFloor) {
  const std::vector<float> v = line(6);
  std::vector<float> imp;
  ASSERT_TRUE(cpu::saliency_field(v.data(), 6, nullptr, 0, {}, 1.0f, &imp, kCpu).ok());
  EXPECT_EQ(imp, std::vector<float>(6, 1.0f));

  // Two far clusters of 4 vertices, k = 3: each cluster's neighbours stay in it,
  // so the cluster without the saliency point is never reached.
  std::vector<float> two;
  for (int i = 0; i < 4; ++i) two.insert(two.end(), {float(i) * 0.1f, 0.0f, 0.0f});
  for (int i = 0; i < 4; ++i) two.insert(two.end(), {100.0f + float(i) * 0.1f, 0.0f, 0.0f});
  const float seed[3] = {-0.05f, 0.0f, 0.0f};
  SaliencyFieldOptions o;
  o.k = 3;
  o.min_importance = 0.3f;
  ASSERT_TRUE(cpu::saliency_field(two.data(), 8, seed, 1, o, 1.0f, &imp, kCpu).ok());
  for (int i = 0; i < 4; ++i) EXPECT_GE(imp[i], 0.69f) << i;  // depths 1-2
  for (int i = 4; i < 8; ++i) EXPECT_EQ(imp[i], 0.3f) << i;
}

TEST(SaliencyField, RejectsBadOptions) {
  const std::vector<float> v = line(20);
  const float seed[3] = {0, 0, 0};
  std::vector<float> imp;
  auto run = [&](SaliencyFieldOptions o, float scale) {
    return cpu::saliency_field(v.data(), 20, seed, 1, o, scale, &imp, kCpu).code();
  };
  SaliencyFieldOptions o;
  EXPECT_EQ(run(o, 1.0f), StatusCode::kOk);
  EXPECT_EQ(run(o, 0.5f), StatusCode::kInvalidArgument);
  EXPECT_EQ(run(o, NAN), StatusCode::kInvalidArgument);
  EXPECT_EQ(run(o, INFINITY), StatusCode::kInvalidArgument);
  for (float beta : {0.0f, 1.0f, -0.5f, NAN}) {
    SaliencyFieldOptions b;
    b.beta = beta;
    EXPECT_EQ(run(b, 1.0f), StatusCode::kInvalidArgument) << beta;
  }
  for (float floor : {0.0f, 1.5f, NAN}) {
    SaliencyFieldOptions f;
    f.min_importance = floor;
    EXPECT_EQ(run(f, 1.0f), StatusCode::kInvalidArgument) << floor;
  }
  SaliencyFieldOptions kz;
  kz.k = 0;
  EXPECT_EQ(run(kz, 1.0f), StatusCode::kInvalidArgument);
  SaliencyFieldOptions big;
  big.k = 21;  // 21 nodes in all
  EXPECT_EQ(run(big, 1.0f), StatusCode::kInvalidArgument);
}

TEST(SaliencyField, ResolvesDepthScale) {
  SaliencyFieldOptions o;
  EXPECT_EQ(resolve_depth_scale(o, 4.0, 0.5), 8.0f);
  EXPECT_EQ(resolve_depth_scale(o, 0.1, 0.5), 1.0f);  // never below 1
  EXPECT_EQ(resolve_depth_scale(o, 1.0, 0.0), 1.0f);  // no edges: ratio undefined
  o.depth_scale = 3.0f;
  EXPECT_EQ(resolve_depth_scale(o, 4.0, 0.5), 3.0f);
}

// Igea's vertices (binary little-endian PLY, float x y z first).
std::vector<float> load_igea_vertices() {
  std::ifstream in("../shared/models/igea.ply", std::ios::binary);
  if (!in) return {};
  std::string line;
  size_t count = 0;
  while (std::getline(in, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) count = std::stoul(line.substr(15));
  std::vector<float> v(3 * count);
  in.read(reinterpret_cast<char*>(v.data()), std::streamsize(v.size() * sizeof(float)));
  return in ? v : std::vector<float>{};
}

// Igea (134,345 vertices) with 100,000 saliency points near a band of it: the
// field is 1 at the band, decays away from it, and does not depend on threads.
TEST(SaliencyField, IgeaWithAHundredThousandSaliencyPoints) {
  const std::vector<float> v = load_igea_vertices();
  if (v.empty()) GTEST_SKIP() << "../shared/models/igea.ply not found";
  const size_t nv = v.size() / 3;
  ASSERT_EQ(nv, 134345u);
  // Saliency points: jittered copies of the vertices in the lowest 40% by y.
  std::vector<size_t> order(nv);
  for (size_t i = 0; i < nv; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return v[3 * a + 1] < v[3 * b + 1]; });
  std::mt19937 rng(2);
  std::uniform_int_distribution<size_t> pick(0, nv * 2 / 5);
  std::normal_distribution<float> jitter(0.0f, 1e-4f);
  std::vector<float> s(3 * 100000);
  for (size_t i = 0; i < 100000; ++i) {
    const size_t src = order[pick(rng)];
    for (int a = 0; a < 3; ++a) s[3 * i + a] = v[3 * src + a] + jitter(rng);
  }
  SaliencyFieldOptions o;
  std::vector<float> two, one;
  const auto t0 = std::chrono::steady_clock::now();
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    ASSERT_TRUE(cpu::saliency_field(v.data(), nv, s.data(), 100000, o, 1.0f, &two, kCpu).ok());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(cpu::saliency_field(v.data(), nv, s.data(), 100000, o, 1.0f, &one, kCpu).ok());
  }
  EXPECT_EQ(one, two);
  size_t at_one = 0, at_floor = 0;
  for (float x : two) {
    ASSERT_GE(x, o.min_importance);
    ASSERT_LE(x, 1.0f);
    at_one += x == 1.0f;
    at_floor += x == o.min_importance;
  }
  // Most of the band is within one hop; the top of the head is far from it.
  EXPECT_GT(at_one, nv / 4);
  EXPECT_GT(at_floor, nv / 10);
  float low_mean = 0, high_mean = 0;
  for (size_t i = 0; i < nv / 5; ++i) low_mean += two[order[i]], high_mean += two[order[nv - 1 - i]];
  EXPECT_GT(low_mean / (nv / 5), 0.95f);
  EXPECT_LT(high_mean / (nv / 5), 0.25f);
  std::printf(
      "igea field: %zu vertices + 100000 saliency points, k = %d: %.3f s at 2 threads; "
      "%zu at I = 1, %zu at the floor\n",
      nv, o.k, seconds, at_one, at_floor);
}

}  // namespace
}  // namespace vpr
