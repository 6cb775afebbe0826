// sanitized.h -- whether the tests are built with AddressSanitizer or ThreadSanitizer, and
// how much slower that makes them at most: time bounds in tests (a linear-time check, a
// bound on a refusal's delay) are multiplied by it.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIGHTMESH_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define LIGHTMESH_TEST_SANITIZED 1
#endif
#endif

namespace lm::testing {
#ifdef LIGHTMESH_TEST_SANITIZED
inline constexpr bool kSanitized = true;
inline constexpr double kSanitizerSlowdown = 15;  // what the sanitizers' instrumentation costs, at most
#else
inline constexpr bool kSanitized = false;
inline constexpr double kSanitizerSlowdown = 1;
#endif

/// How many cases a sweep runs: all of them in the Release build, `full / divisor` (at least
/// one) under the sanitizers. A sweep's breadth is checked in Release; the sanitizers look at
/// the memory and threads of the code paths, which the first cases of a sweep already take.
constexpr int SweepCases(int full, int divisor) {
    return kSanitized ? (full / divisor > 0 ? full / divisor : 1) : full;
}
}  // namespace lm::testing
