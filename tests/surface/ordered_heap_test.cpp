// OrderedHeapScope: memory in allocation order on this thread only, stray
// deletes tolerated, and meshing that does not depend on the heap's history.
#include "surface/ordered_heap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include "surface/meshing.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VPR_TEST_ASAN 1
#include <sanitizer/asan_interface.h>
#endif
#endif

namespace vpr {
namespace {

TEST(OrderedHeap, AddressesFollowAllocationOrderInsideAScope) {
  std::vector<uintptr_t> addresses;
  addresses.reserve(1000);  // outside the scope: this vector's buffer is malloc's
  {
    OrderedHeapScope scope(64 << 20);
    ASSERT_TRUE(scope.active());
    for (int i = 0; i < 1000; ++i) {
      int* p = new int[1 + (i * 37) % 200];
      addresses.push_back(reinterpret_cast<uintptr_t>(p));
      if (i % 3 == 0) delete[] p;  // freeing inside does not make the next one go back
    }
    EXPECT_FALSE(scope.exhausted());
  }
  for (size_t i = 1; i < addresses.size(); ++i) ASSERT_GT(addresses[i], addresses[i - 1]) << i;
}

TEST(OrderedHeap, OtherThreadsKeepTheOrdinaryHeap) {
  OrderedHeapScope scope(16 << 20);
  ASSERT_TRUE(scope.active());
  char* mine = new char[64];
  uintptr_t theirs = 0;
  std::thread([&] {
    auto p = std::make_unique<char[]>(64);
    theirs = reinterpret_cast<uintptr_t>(p.get());
  }).join();
  // The other thread's block came from malloc, not from this scope's region.
  EXPECT_GT(std::abs(double(theirs) - double(reinterpret_cast<uintptr_t>(mine))), double(16 << 20));
  delete[] mine;
}

// On a fresh thread: a thread reuses its region when it is large enough, and
// earlier tests in this process may have given this one a large region.
TEST(OrderedHeap, ExhaustedScopeFallsBackToTheHeap) {
  bool exhausted = false;
  char value = 0;
  std::thread([&] {
    OrderedHeapScope scope(4096);
    std::vector<char> big(1 << 20, 'x');  // does not fit: comes from malloc, still usable
    exhausted = scope.exhausted();
    value = big[12345];
  }).join();
  EXPECT_TRUE(exhausted);
  EXPECT_EQ(value, 'x');
}

// Under AddressSanitizer the region is checked like malloc's heap: the bytes
// after a block, and a block whose scope has ended, are poisoned. The scopes
// grow, so the thread's region is replaced; LeakSanitizer checks that the old
// region's record is freed.
TEST(OrderedHeap, AddressSanitizerSeesPastABlockAndAfterTheScope) {
#if VPR_TEST_ASAN
  // No gtest assertion inside a scope: its records would live in the region.
  for (size_t bytes : {size_t(1) << 16, size_t(1) << 20, size_t(1) << 24}) {
    char* p = nullptr;
    bool active = false, last_byte_poisoned = true, next_byte_poisoned = false;
    {
      OrderedHeapScope scope(bytes);
      active = scope.active();
      p = new char[10];
      last_byte_poisoned = __asan_address_is_poisoned(p + 9);
      next_byte_poisoned = __asan_address_is_poisoned(p + 10);
      delete[] p;  // a no-op inside a scope
    }
    ASSERT_TRUE(active);
    EXPECT_FALSE(last_byte_poisoned);
    EXPECT_TRUE(next_byte_poisoned);
    EXPECT_TRUE(__asan_address_is_poisoned(p));
  }
#else
  GTEST_SKIP() << "needs AddressSanitizer (make sanitize)";
#endif
}

// The same points give the same faces however fragmented the heap is.
TEST(OrderedHeap, MeshingIgnoresTheHeapsHistory) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<float> points;
  const int n = 3000;
  for (int i = 0; i < n; ++i) {
    const double z = 2 * u(rng) - 1, t = 2 * M_PI * u(rng), r = std::sqrt(1 - z * z);
    const double s = 1 + 0.2 * std::sin(4 * z) * std::cos(3 * t);
    for (double c : {r * std::cos(t) * s, r * std::sin(t) * s, z * s}) points.push_back(float(c));
  }
  Mesh first;
  ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &first, nullptr, nullptr).ok());
  std::vector<std::unique_ptr<char[]>> junk;
  for (int round = 0; round < 4; ++round) {
    for (int j = 0; j < 20000; ++j) junk.emplace_back(new char[16 + (j * 7919 + round * 131) % 2000]);
    for (size_t j = round % 2; j < junk.size(); j += 2) junk[j].reset();  // holes of every size
    Mesh again;
    ASSERT_TRUE(mesh_points(points.data(), n, MeshingOptions{}, &again, nullptr, nullptr).ok());
    EXPECT_EQ(again.indices, first.indices) << "round " << round;
  }
}

}  // namespace
}  // namespace vpr
