// A union-find for many threads at once: links always point from a larger
// root to a smaller one, by compare-and-swap (lock-free; Anderson and Woll
// 1991). Whatever order the threads link in, each set ends rooted at its
// lowest element, which is never linked below anything: the result does not
// depend on the schedule. Shared by the mesh's face parts (core/mesh_parts.*)
// and the edge graph's parts (surface/edge_parts.*).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <utility>

namespace vpr {

class ConcurrentParents {
 public:
  explicit ConcurrentParents(size_t n) : up_(new std::atomic<uint32_t>[n]) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) up_[v].store(uint32_t(v), std::memory_order_relaxed);
    });
  }

  // The root of v, halving the path on the way (a shortcut any thread may
  // take: it only ever points an element at one of its ancestors).
  uint32_t find(uint32_t v) {
    for (;;) {
      uint32_t p = up_[v].load(std::memory_order_acquire);
      if (p == v) return v;
      const uint32_t g = up_[p].load(std::memory_order_acquire);
      if (g != p) up_[v].compare_exchange_weak(p, g, std::memory_order_acq_rel);
      v = g;
    }
  }

  void unite(uint32_t a, uint32_t b) {
    for (;;) {
      a = find(a);
      b = find(b);
      if (a == b) return;
      if (a < b) std::swap(a, b);  // link the larger root under the smaller
      uint32_t expected = a;
      if (up_[a].compare_exchange_strong(expected, b, std::memory_order_acq_rel)) return;
    }  // a was linked meanwhile: find its new root and try again
  }

 private:
  std::unique_ptr<std::atomic<uint32_t>[]> up_;
};

}  // namespace vpr
