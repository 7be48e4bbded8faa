#include "surface/ordered_heap.h"

#include <sys/mman.h>

#include <atomic>
#include <cstdint>
#include <algorithm>
#include <cstdlib>
#include <new>

// Under AddressSanitizer each block handed out is followed by a poisoned
// redzone, and a scope poisons what it used when it ends, so that an overflow
// inside AFSR is reported as it is on malloc's heap, and so is a block used
// after its scope.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VPR_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define VPR_ASAN 1
#endif
#ifdef VPR_ASAN
#include <sanitizer/asan_interface.h>
constexpr size_t kRedzone = 32;
#else
#define ASAN_POISON_MEMORY_REGION(addr, size) ((void)(addr), (void)(size))
#define ASAN_UNPOISON_MEMORY_REGION(addr, size) ((void)(addr), (void)(size))
constexpr size_t kRedzone = 0;
#endif

namespace vpr {

// A thread's region: one private mapping, reused by every scope on that
// thread (used resets to 0), and never unmapped, so that the kernel never
// hands its addresses to malloc and operator delete can always tell ours from
// malloc's. Between scopes its pages are given back (MADV_DONTNEED); only the
// address range stays reserved. A scope that asks for more than the thread's
// region holds gets a new, larger one; the old one stays reserved, empty.
struct Region {
  char* base = nullptr;
  size_t size = 0;
  size_t used = 0;
  bool exhausted = false;
};

namespace {

thread_local Region* t_region = nullptr;    // while a scope is alive
// This thread's region, between scopes too. Its record is freed when the
// thread exits or gets a larger region; the address range stays reserved and
// remembered in g_lo/g_hi, which is all operator delete needs.
struct Reserved {
  Region* region = nullptr;
  ~Reserved() { std::free(region); }
};
thread_local Reserved t_reserved;

// Every region's address range, for operator delete (lock-free reads).
constexpr int kMaxRanges = 1024;
std::atomic<uintptr_t> g_lo[kMaxRanges], g_hi[kMaxRanges];
std::atomic<int> g_count{0};

bool in_our_region(const void* p) {
  const uintptr_t a = reinterpret_cast<uintptr_t>(p);
  const int n = std::min(g_count.load(std::memory_order_acquire), kMaxRanges);
  for (int i = 0; i < n; ++i)
    if (a >= g_lo[i].load(std::memory_order_relaxed) && a < g_hi[i].load(std::memory_order_relaxed)) return true;
  return false;
}

bool remember_range(const Region& r) {
  const int slot = g_count.load();
  if (slot >= kMaxRanges) return false;
  g_lo[slot].store(reinterpret_cast<uintptr_t>(r.base));
  g_hi[slot].store(reinterpret_cast<uintptr_t>(r.base) + r.size);
  g_count.store(slot + 1, std::memory_order_release);
  return true;
}

std::atomic_flag g_register_lock = ATOMIC_FLAG_INIT;

Region* map_region(size_t bytes) {
  void* base = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (base == MAP_FAILED) return nullptr;
  Region* r = static_cast<Region*>(std::malloc(sizeof(Region)));
  if (!r) {
    munmap(base, bytes);
    return nullptr;
  }
  *r = Region{static_cast<char*>(base), bytes, 0, false};
  while (g_register_lock.test_and_set(std::memory_order_acquire)) {
  }
  const bool ok = remember_range(*r);
  g_register_lock.clear(std::memory_order_release);
  if (!ok) {  // too many regions: ordering cannot be offered safely
    munmap(base, bytes);
    std::free(r);
    return nullptr;
  }
  return r;
}

void* take(Region* r, size_t n, size_t align) {
  const size_t at = (r->used + align - 1) & ~(align - 1);
  if (at + n + kRedzone > r->size) {
    r->exhausted = true;
    return nullptr;
  }
  ASAN_POISON_MEMORY_REGION(r->base + r->used, at - r->used);  // alignment padding
  ASAN_UNPOISON_MEMORY_REGION(r->base + at, n);
  ASAN_POISON_MEMORY_REGION(r->base + at + n, kRedzone);
  r->used = at + n + kRedzone;
  return r->base + at;
}

void* allocate(size_t n, size_t align) {
  if (n == 0) n = 1;
  if (t_region)
    if (void* p = take(t_region, n, align)) return p;
  void* p = align > alignof(std::max_align_t) ? std::aligned_alloc(align, (n + align - 1) / align * align)
                                              : std::malloc(n);
  if (!p) throw std::bad_alloc();
  return p;
}

void release(void* p) noexcept {
  if (p && !in_our_region(p)) std::free(p);
}

}  // namespace

OrderedHeapScope::OrderedHeapScope(size_t bytes) {
  if (t_region) return;  // nested: the outer scope already orders this thread
  Region*& reserved = t_reserved.region;
  if (!reserved || reserved->size < bytes) {
    Region* fresh = map_region(bytes);
    if (!fresh) return;
    if (reserved) {
      madvise(reserved->base, reserved->size, MADV_DONTNEED);  // keep it reserved, empty
      std::free(reserved);
    }
    reserved = fresh;
  }
  reserved->used = 0;
  reserved->exhausted = false;
  region_ = reserved;
  t_region = region_;
}

OrderedHeapScope::~OrderedHeapScope() {
  if (!region_) return;
  t_region = nullptr;
  madvise(region_->base, region_->used, MADV_DONTNEED);  // pages back to the system, addresses kept
  ASAN_POISON_MEMORY_REGION(region_->base, region_->used);
}

bool OrderedHeapScope::exhausted() const {
  return region_ && region_->exhausted;
}

}  // namespace vpr

// The replaceable global allocation functions ([new.delete]): every operator
// new of the process comes here; outside a scope it is plain malloc.
void* operator new(std::size_t n) { return vpr::allocate(n, alignof(std::max_align_t)); }
void* operator new[](std::size_t n) { return vpr::allocate(n, alignof(std::max_align_t)); }
void* operator new(std::size_t n, std::align_val_t a) { return vpr::allocate(n, size_t(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return vpr::allocate(n, size_t(a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return vpr::allocate(n, alignof(std::max_align_t));
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return vpr::allocate(n, alignof(std::max_align_t));
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { vpr::release(p); }
void operator delete[](void* p) noexcept { vpr::release(p); }
void operator delete(void* p, std::size_t) noexcept { vpr::release(p); }
void operator delete[](void* p, std::size_t) noexcept { vpr::release(p); }
void operator delete(void* p, std::align_val_t) noexcept { vpr::release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { vpr::release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { vpr::release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { vpr::release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { vpr::release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { vpr::release(p); }
