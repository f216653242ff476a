#pragma once
// The fit's kernel set a test process should be running (fit/src/kernels/), worked out apart
// from dispatch.cpp: what the processor reports, and SKINSPEC_FIT_KERNELS, which the tests set
// to run the suites again on the narrower sets.

#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "kernels/kernels.hpp"  // fit/src

namespace skinspec::testing {

// Whether the processor (not the build) has what each set needs.
inline bool processor_has(detail::KernelSet set) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (set == detail::KernelSet::avx2) return avx2;
  if (set == detail::KernelSet::avx512)
    return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("avx512dq");
  return true;
#else
  return set == detail::KernelSet::generic;
#endif
}

// The sets this build and processor run, narrowest first.
inline std::vector<detail::KernelSet> runnable_kernel_sets() {
  std::vector<detail::KernelSet> sets;
  for (const auto set : {detail::KernelSet::generic, detail::KernelSet::avx2, detail::KernelSet::avx512})
    if (processor_has(set)) sets.push_back(set);
  return sets;
}

// What SKINSPEC_FIT_KERNELS calls each set.
inline std::string_view kernel_set_name(detail::KernelSet set) {
  constexpr std::string_view names[] = {"generic", "avx2", "avx512"};
  return names[static_cast<int>(set)];
}

// The set asked for by name if it runs here, otherwise the widest that does. Says so in the
// output when none was asked for: the runs meant for a narrower set refuse that output, so that
// an environment that did not reach them fails them (tests/CMakeLists.txt).
inline detail::KernelSet expected_kernel_set() {
  const char* asked = std::getenv("SKINSPEC_FIT_KERNELS");
  if (asked == nullptr) std::printf("no kernel set was asked for (SKINSPEC_FIT_KERNELS)\n");
  const auto sets = runnable_kernel_sets();
  for (const auto set : sets)
    if (asked != nullptr && kernel_set_name(set) == asked) return set;
  return sets.back();
}

}  // namespace skinspec::testing
