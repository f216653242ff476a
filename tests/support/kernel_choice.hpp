#pragma once
// The fit's kernels a test process should be running (fit/src/kernels/), worked out apart from
// Highway: what the processor reports, and SKINSPEC_FIT_KERNELS, which the tests set to check
// that a target can be asked for.

#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>
#include <string_view>

namespace skinspec::testing {

// Whether the processor reports what Highway's x86 target of this name needs (AVX3: AVX-512 F,
// VL, DQ and BW; AVX2: AVX2 and FMA); other targets are not judged here.
inline bool x86_processor_has(std::string_view target) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (target == "avx2") return avx2;
  if (target == "avx3")
    return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw");
#endif
  (void)target;
  return false;
}

// The target asked for by name if it is runnable (names: best first), otherwise the best. Says so
// in the output when none was asked for: the runs meant for another target refuse that output, so
// that an environment that did not reach them fails them (tests/CMakeLists.txt).
inline std::string expected_kernels(std::span<const std::string> runnable) {
  const char* asked = std::getenv("SKINSPEC_FIT_KERNELS");
  if (asked == nullptr) std::printf("no kernel set was asked for (SKINSPEC_FIT_KERNELS)\n");
  for (const std::string& name : runnable)
    if (asked != nullptr && name == asked) return name;
  return runnable.front();
}

}  // namespace skinspec::testing
