#include "surface/edge_parts.h"

#include <tbb/parallel_for.h>

#include <atomic>
#include <memory>
#include <utility>

namespace vpr {
namespace {

// A union-find whose links always point from a larger root to a smaller one,
// by compare-and-swap (lock-free; Anderson and Woll 1991). Whatever order the
// threads link in, each part ends rooted at its lowest vertex, which is
// never linked below anything: the result does not depend on the schedule.
class ConcurrentParents {
 public:
  explicit ConcurrentParents(size_t n) : up_(new std::atomic<uint32_t>[n]) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16384), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t v = r.begin(); v != r.end(); ++v) up_[v].store(uint32_t(v), std::memory_order_relaxed);
    });
  }

  // The root of v, halving the path on the way (a shortcut any thread may
  // take: it only ever points a vertex at one of its ancestors).
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

}  // namespace

EdgeParts edge_parts(const MeshEdges& edges) {
  const size_t nv = edges.vertex_count();
  ConcurrentParents parents(nv);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v)
      for (const uint32_t* w = edges.begin(v); w != edges.end(v); ++w)
        if (*w > v) parents.unite(v, *w);  // each edge once
  });
  std::vector<uint32_t> root(nv);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, uint32_t(nv), 16384), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t v = r.begin(); v != r.end(); ++v) root[v] = parents.find(v);
  });
  // Numbered by lowest vertex (each root is its part's lowest vertex, so it
  // comes before the part's other vertices), as a walk from each vertex not
  // yet reached, in index order, numbers them.
  EdgeParts out;
  out.part.assign(nv, UINT32_MAX);
  for (uint32_t v = 0; v < nv; ++v) {
    if (edges.degree(v) == 0) continue;
    if (root[v] == v) {
      out.part[v] = uint32_t(out.elements.size());
      out.elements.emplace_back();
    } else {
      out.part[v] = out.part[root[v]];
    }
    out.elements[out.part[v]].push_back(v);
  }
  return out;
}

}  // namespace vpr
