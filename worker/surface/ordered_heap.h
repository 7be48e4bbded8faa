// Allocation-ordered memory for CGAL's advancing front.
//
// AFSR keeps its candidate border edges in a std::set ordered by (priority,
// pointer to the edge's record), and many candidates share a priority (every
// "standby" candidate has the same constant). Ties are therefore broken by
// heap addresses, and the reconstruction changes with the heap's history: the
// same points gave different faces in one process on the H100 machine
// (measured: PipelineGpu.SameInputGivesIdenticalOutputOnTheGpu). While an
// OrderedHeapScope is alive on a thread, operator new on that thread hands out
// memory from a private region in increasing address order, so addresses, and
// with them the ties, follow the order of allocation, which is deterministic.
//
// Rules for code inside a scope: nothing allocated with operator new inside
// (std::vector, std::string, ...) may be used after the scope ends; copy
// results out through malloc'ed buffers. Other threads are not affected.
#pragma once

#include <cstddef>

#include "core/status.h"

namespace vpr {

class OrderedHeapScope {
 public:
  // bytes: the most the scope may take; past it, operator new falls back to
  // the ordinary heap (correct, but ordered no more) and exhausted() says so.
  explicit OrderedHeapScope(size_t bytes);
  ~OrderedHeapScope();
  OrderedHeapScope(const OrderedHeapScope&) = delete;
  OrderedHeapScope& operator=(const OrderedHeapScope&) = delete;

  bool active() const { return region_ != nullptr; }  // false: no region could be mapped
  bool exhausted() const;

 private:
  struct Region* region_ = nullptr;
};

}  // namespace vpr
