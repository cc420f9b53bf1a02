#pragma once
// The length of the test suite's long runs: 10⁶ steps, 10⁵ under AddressSanitizer (the
// sanitizer stage is ~10× slower; GCC defines __SANITIZE_ADDRESS__, clang answers
// __has_feature).

namespace trompo_test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr long long_run = 100000;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr long long_run = 100000;
#else
inline constexpr long long_run = 1000000;
#endif
#else
inline constexpr long long_run = 1000000;
#endif

}  // namespace trompo_test
