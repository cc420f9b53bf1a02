#pragma once
// Counts heap allocations, for the tests that prove a step allocates nothing. Include it
// FIRST in the test file (before Catch2, Eigen or trompo), in one translation unit per
// executable: it replaces the global operator new/delete of that executable.
//  - every replaceable operator new/delete is replaced by a counting one (every form, so
//    that no allocation escapes the count and every pointer is released by the matching
//    function: AddressSanitizer checks the pairing);
//  - Eigen's own heap (aligned_malloc, which bypasses operator new) is watched with
//    EIGEN_RUNTIME_NO_MALLOC, whose check goes through eigen_assert, defined here so that
//    it records a violation in Release builds too (where the plain assert is compiled out).
#include <atomic>
#include <cstdlib>
#include <new>

namespace no_alloc {
/// Violations of EIGEN_RUNTIME_NO_MALLOC (or of any other Eigen assertion) in this executable.
inline std::atomic<long> eigen_violations{0};
inline void eigen_violation(const char* /*what*/) { ++eigen_violations; }
/// operator new calls while `counting` is set.
inline std::atomic<long> news{0};
inline std::atomic<bool> counting{false};

inline void* counted(std::size_t n) {
  if (counting.load(std::memory_order_relaxed)) ++news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
inline void* counted_aligned(std::size_t n, std::align_val_t a) {
  if (counting.load(std::memory_order_relaxed)) ++news;
  const std::size_t al = static_cast<std::size_t>(a);
  if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
  throw std::bad_alloc();
}
}  // namespace no_alloc

#define EIGEN_RUNTIME_NO_MALLOC
#define eigen_assert(x)                                       \
  do {                                                        \
    if (!static_cast<bool>(x)) no_alloc::eigen_violation(#x); \
  } while (false)

void* operator new(std::size_t n) { return no_alloc::counted(n); }
void* operator new[](std::size_t n) { return no_alloc::counted(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return no_alloc::counted(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return no_alloc::counted(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t n, std::align_val_t a) { return no_alloc::counted_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return no_alloc::counted_aligned(n, a); }
// g++ 12 at -O1 and above, once a container's deallocation is inlined into a test, sees
// free() on a pointer from operator new and warns (-Wmismatched-new-delete): these are the
// replacements of both, which pair malloc with free, so the warning is silenced here.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

#include <Eigen/Core>

namespace no_alloc {
/// Runs f with allocation watched; returns the number of operator new calls plus Eigen
/// heap allocations attempted inside.
template <class F>
long allocations_in(F&& f) {
  const long eigen_before = eigen_violations.load();
  news = 0;
  Eigen::internal::set_is_malloc_allowed(false);
  counting = true;
  f();
  counting = false;
  Eigen::internal::set_is_malloc_allowed(true);
  return news.load() + (eigen_violations.load() - eigen_before);
}
}  // namespace no_alloc
