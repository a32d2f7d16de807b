// PVDF_ASSERT(condition, message): the check of an internal invariant, one that holds by
// construction whatever the input (array sizes that agree, an index in range, probabilities that
// sum to 1, a sorted grid). A broken one is a bug in pvdfkit: the check prints
//   file:line: internal invariant broken: `condition`: message
// to stderr and aborts. Bad input is never asserted: it stays an InputError (exit code 2).
//
// On when NDEBUG is not defined (CMAKE_BUILD_TYPE=Debug: the sanitized build of
// scripts/run-sanitized-tests), off in Release and RelWithDebInfo, where the condition is compiled
// (its names stay used and checked) but never evaluated. -DPVDF_ASSERTIONS=1 or =0 overrides.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#ifndef PVDF_ASSERTIONS
#ifdef NDEBUG
#define PVDF_ASSERTIONS 0
#else
#define PVDF_ASSERTIONS 1
#endif
#endif

namespace pvdf::detail {

[[noreturn]] inline void assertion_failed(const char* file, int line, const char* condition, const char* message) noexcept {
  std::fprintf(stderr, "%s:%d: internal invariant broken: `%s`: %s\n", file, line, condition, message);
  std::fflush(stderr);
  std::abort();
}

[[noreturn]] inline void assertion_failed(const char* file, int line, const char* condition,
                                          const std::string& message) noexcept {
  assertion_failed(file, line, condition, message.c_str());
}

}  // namespace pvdf::detail

#if PVDF_ASSERTIONS
#define PVDF_ASSERT(condition, message)                                                 \
  ((condition) ? static_cast<void>(0)                                                   \
               : ::pvdf::detail::assertion_failed(__FILE__, __LINE__, #condition, message))
#else
#define PVDF_ASSERT(condition, message) static_cast<void>(false && (condition))
#endif
