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

/// The counter: switch `counting` on around the code under test and read `count`.
struct AllocationCounter {
  static inline bool counting = false;  ///< count calls while true
  static inline long count = 0;         ///< calls counted (allocations and frees)
  /// Counts one call if counting.
  static void hit() {
    if (counting) ++count;
  }
};

/// Counts the allocations of a scope: switches counting on (from zero) for its lifetime.
class AllocationWindow {
 public:
  AllocationWindow() {
    AllocationCounter::count = 0;
    AllocationCounter::counting = true;
  }
  ~AllocationWindow() { AllocationCounter::counting = false; }
  AllocationWindow(const AllocationWindow&) = delete;
  AllocationWindow& operator=(const AllocationWindow&) = delete;
  /// @return the calls counted so far in this window.
  long count() const { return AllocationCounter::count; }
};

}  // namespace tubempc_testing

#if defined(__GLIBC__) && !defined(TUBEMPC_ALLOCATION_COUNTER_SANITIZED)
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
void* __libc_memalign(std::size_t, std::size_t);

void* malloc(std::size_t n) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_realloc(p, n);
}
void free(void* p) noexcept {
  if (p != nullptr) tubempc_testing::AllocationCounter::hit();
  __libc_free(p);
}
void* memalign(std::size_t alignment, std::size_t n) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_memalign(alignment, n);
}
void* aligned_alloc(std::size_t alignment, std::size_t n) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_memalign(alignment, n);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t n) noexcept {
  tubempc_testing::AllocationCounter::hit();
  *out = __libc_memalign(alignment, n);
  return *out != nullptr ? 0 : 12;  // ENOMEM
}
}

void* operator new(std::size_t n) {
  tubempc_testing::AllocationCounter::hit();
  if (void* p = __libc_malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  tubempc_testing::AllocationCounter::hit();
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void* operator new(std::size_t n, std::align_val_t a) {
  tubempc_testing::AllocationCounter::hit();
  if (void* p = __libc_memalign(static_cast<std::size_t>(a), n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void operator delete(void* p) noexcept {
  if (p != nullptr) tubempc_testing::AllocationCounter::hit();
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
