/// @file allocation_counter.hpp
/// Counts heap allocations, for checks that a code path allocates nothing (the MPC step after setup).
/// Test support, not part of tubempc's installed headers: the allocation tests (tests/cpp/*_alloc,
/// tests/cpp/*/test_*no_allocation.cpp) and examples/cpp/closed_loop include it from the source tree
/// (include directory tests/cpp/support).
///
/// Including this header defines the program's global malloc family (malloc, calloc, realloc, free,
/// memalign, aligned_alloc, posix_memalign) and every global operator new and delete, forwarding to
/// glibc's own allocator through its __libc_* entry points; while `AllocationCounter::counting` is
/// true each call is counted, so allocations by the core, Eigen, PIQP, the standard library and C
/// code are all seen. Include it in exactly one translation unit of a program, outside any namespace.
/// It is active with glibc and without AddressSanitizer (which replaces malloc itself); otherwise it
/// defines only the counter, `kAllocationCounterEnabled` is false and nothing is counted.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <new>

#if defined(__SANITIZE_ADDRESS__)
#define TUBEMPC_ALLOCATION_COUNTER_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TUBEMPC_ALLOCATION_COUNTER_SANITIZED 1
#endif
#endif

namespace tubempc_testing {

#if defined(__GLIBC__) && !defined(TUBEMPC_ALLOCATION_COUNTER_SANITIZED)
/// Whether this build counts allocations (glibc, no AddressSanitizer).
inline constexpr bool kAllocationCounterEnabled = true;
#else
/// Whether this build counts allocations (glibc, no AddressSanitizer).
inline constexpr bool kAllocationCounterEnabled = false;
#endif

/// The counter: switch `counting` on around the code under test and read `count` and the bytes. Bytes are
/// the blocks' usable sizes (glibc's malloc_usable_size: the request rounded up to the allocator's chunk).
struct AllocationCounter {
  static inline bool counting = false;          ///< count calls while true
  static inline long count = 0;                 ///< calls counted (allocations and frees)
  static inline long long allocated_bytes = 0;  ///< bytes of the blocks allocated while counting
  static inline long long live_bytes =
      0;  ///< allocated minus freed bytes while counting (< 0: older blocks freed)
  static inline long long peak_live_bytes = 0;  ///< the largest live_bytes seen while counting
  /// Counts an allocation of a block of `usable` bytes (0: the allocation failed) if counting.
  static void allocated(std::size_t usable) {
    if (!counting) return;
    ++count;
    allocated_bytes += static_cast<long long>(usable);
    live_bytes += static_cast<long long>(usable);
    if (live_bytes > peak_live_bytes) peak_live_bytes = live_bytes;
  }
  /// Counts a reallocation (one call) that released `released` bytes and holds a block of `usable` bytes.
  static void reallocated(std::size_t released, std::size_t usable) {
    if (!counting) return;
    live_bytes -= static_cast<long long>(released);
    allocated(usable);
  }
  /// Counts the release of a block of `usable` bytes if counting.
  static void freed(std::size_t usable) {
    if (!counting) return;
    ++count;
    live_bytes -= static_cast<long long>(usable);
  }
};

/// Counts the allocations of a scope: switches counting on (from zero) for its lifetime.
class AllocationWindow {
 public:
  AllocationWindow() {
    AllocationCounter::count = 0;
    AllocationCounter::allocated_bytes = AllocationCounter::live_bytes = AllocationCounter::peak_live_bytes =
        0;
    AllocationCounter::counting = true;
  }
  ~AllocationWindow() { AllocationCounter::counting = false; }
  AllocationWindow(const AllocationWindow&) = delete;
  AllocationWindow& operator=(const AllocationWindow&) = delete;
  /// @return the calls counted so far in this window.
  long count() const { return AllocationCounter::count; }
  /// @return the bytes allocated so far in this window (freed or not).
  long long allocated_bytes() const { return AllocationCounter::allocated_bytes; }
  /// @return the bytes allocated and not freed in this window so far: what the scope keeps (bytes).
  long long retained_bytes() const { return AllocationCounter::live_bytes; }
  /// @return the most bytes the window's allocations held at once (bytes).
  long long peak_bytes() const { return AllocationCounter::peak_live_bytes; }
};

}  // namespace tubempc_testing

#if defined(__GLIBC__) && !defined(TUBEMPC_ALLOCATION_COUNTER_SANITIZED)
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
void* __libc_memalign(std::size_t, std::size_t);
std::size_t malloc_usable_size(void*) noexcept;

namespace {
// The block `p` just allocated, counted; returns it.
void* tubempc_counted(void* p) noexcept {
  tubempc_testing::AllocationCounter::allocated(p != nullptr ? malloc_usable_size(p) : 0);
  return p;
}
}  // namespace

void* malloc(std::size_t n) noexcept { return tubempc_counted(__libc_malloc(n)); }
void* calloc(std::size_t n, std::size_t size) noexcept { return tubempc_counted(__libc_calloc(n, size)); }
void* realloc(void* p, std::size_t n) noexcept {
  const std::size_t old = p != nullptr ? malloc_usable_size(p) : 0;
  void* q = __libc_realloc(p, n);
  // the old block is released when the call succeeds, or when it frees (n == 0) and returns null
  const bool released = p != nullptr && (q != nullptr || n == 0);
  tubempc_testing::AllocationCounter::reallocated(released ? old : 0,
                                                  q != nullptr ? malloc_usable_size(q) : 0);
  return q;
}
void free(void* p) noexcept {
  if (p != nullptr) tubempc_testing::AllocationCounter::freed(malloc_usable_size(p));
  __libc_free(p);
}
void* memalign(std::size_t alignment, std::size_t n) noexcept {
  return tubempc_counted(__libc_memalign(alignment, n));
}
void* aligned_alloc(std::size_t alignment, std::size_t n) noexcept {
  return tubempc_counted(__libc_memalign(alignment, n));
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) noexcept {
  *out = tubempc_counted(__libc_memalign(alignment, n));
  return *out != nullptr ? 0 : 12;  // ENOMEM
}
}

void* operator new(std::size_t n) {
  if (void* p = tubempc_counted(__libc_malloc(n == 0 ? 1 : n))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return tubempc_counted(__libc_malloc(n == 0 ? 1 : n));
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) {
  if (void* p = tubempc_counted(__libc_memalign(static_cast<std::size_t>(a), n == 0 ? 1 : n))) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept {
  if (p != nullptr) tubempc_testing::AllocationCounter::freed(malloc_usable_size(p));
  __libc_free(p);
}
void operator delete[](void* p) noexcept { operator delete(p); }
void operator delete(void* p, std::size_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::size_t) noexcept { operator delete(p); }
void operator delete(void* p, std::align_val_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::align_val_t) noexcept { operator delete(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { operator delete(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { operator delete(p); }
#endif
