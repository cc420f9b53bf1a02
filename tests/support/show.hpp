#pragma once
// What a test prints beside its assertions, without Catch2 warnings:
//
//   SHOW("HT1 h = 0.001: dH " << dH << ", dmu " << dmu);   // a measured figure, on stdout
//   trompo_test::skip("trompo/exact needs Boost.Math");     // the test case did not run
//
// SHOW writes one line to stdout, prefixed by the running test case's name: always, not
// only with -s. A green run thus shows no warnings; the figures are in the test's output
// (ctest -V, or ctest --output-on-failure when it fails, or the binary run by hand).
//
// skip() prints kSkipMarker and the reason. tests/CMakeLists.txt gives every test
// SKIP_REGULAR_EXPRESSION on that marker, so ctest reports such a test as skipped, not
// passed (Catch2 v2 has no skip of its own).
#include <catch2/catch.hpp>

#include <iostream>
#include <sstream>
#include <string>

namespace trompo_test {

/// The text ctest's SKIP_REGULAR_EXPRESSION looks for (tests/CMakeLists.txt).
inline constexpr const char* kSkipMarker = "TROMPO-TEST-SKIPPED: ";

/// One line of figures on stdout, after the running test case's name.
inline void show_line(const std::string& text) {
  std::cout << '[' << Catch::getResultCapture().getCurrentTestName() << "] " << text << std::endl;
}

/// Marks the running test case as skipped for ctest, with the reason.
inline void skip(const std::string& reason) { std::cout << kSkipMarker << reason << std::endl; }

}  // namespace trompo_test

/// SHOW(a << b << …): a measured figure on stdout (see the file comment); a stream
/// expression as Catch2's WARN and INFO take.
#define SHOW(...)                                     \
  do {                                                \
    ::std::ostringstream trompo_show_stream_;         \
    trompo_show_stream_ << __VA_ARGS__;               \
    ::trompo_test::show_line(trompo_show_stream_.str()); \
  } while (false)
