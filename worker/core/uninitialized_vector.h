// A std::vector whose resize leaves new elements of a trivial type unset:
// its allocator default-initializes where std::allocator value-initializes.
// std::vector<uint32_t>(n) zero-fills on one thread, which on a pass over a
// million faces costs as much as the pass's parallel loops (the refinement:
// surface_refine.cpp); with this, a parallel loop writes each element once.
// Every element must be written before it is read.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace vpr {

template <class T, class Base = std::allocator<T>>
class DefaultInitAllocator : public Base {
 public:
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U, typename std::allocator_traits<Base>::template rebind_alloc<U>>;
  };
  using Base::Base;
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U, typename std::allocator_traits<Base>::template rebind_alloc<U>>& o)
      : Base(o) {}

  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;  // default-initialized: unset for a trivial U
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<Base>::construct(static_cast<Base&>(*this), p, std::forward<Args>(args)...);
  }
};

template <class T>
using UninitializedVector = std::vector<T, DefaultInitAllocator<T>>;

// Sized to n without keeping the old contents: a fresh block when n passes
// the capacity (with an eighth more, for the next small growth), so that
// nothing is copied only to be overwritten.
template <class T>
void resize_for_overwrite(UninitializedVector<T>* v, size_t n) {
  if (n > v->capacity()) {
    UninitializedVector<T> fresh;
    fresh.reserve(n + n / 8);
    *v = std::move(fresh);
  }
  v->resize(n);
}

}  // namespace vpr
