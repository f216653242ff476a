// Which kernel set runs (kernels.hpp): the widest this build has and the processor can run,
// unless SKINSPEC_FIT_KERNELS names another it can run (so that the tests check every set on one
// machine, and a processor slower with 512-bit vectors can be kept on AVX2).

#include "kernels.hpp"

#include <atomic>
#include <cstdlib>
#include <iterator>
#include <string_view>

namespace skinspec::detail {

namespace {

#if defined(SKINSPEC_FIT_AVX_KERNELS) && defined(__x86_64__)
constexpr bool kBuiltWithAvx = true;
#else
constexpr bool kBuiltWithAvx = false;
#endif

// libgcc's checks include the operating system's: it must save the wider registers.
bool processor_runs(KernelSet set) {
#if defined(__x86_64__)
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  switch (set) {
    case KernelSet::generic:
      return true;
    case KernelSet::avx2:
      return avx2;
    case KernelSet::avx512:
      return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512dq");
  }
  return false;
#else
  return set == KernelSet::generic;
#endif
}

KernelSet chosen() {
  const char* asked = std::getenv("SKINSPEC_FIT_KERNELS");
  KernelSet widest = KernelSet::generic;
  for (const KernelSet set : kKernelSets) {
    if (!kernel_set_available(set)) continue;
    if (asked != nullptr && std::string_view(asked) == kernels_of(set).name) return set;
    widest = set;
  }
  return widest;
}

std::atomic<const FitKernels*>& active() {
  static std::atomic<const FitKernels*> kernels{&kernels_of(chosen())};
  return kernels;
}

}  // namespace

bool kernel_set_available(KernelSet set) {
  static const bool runs[] = {true, kBuiltWithAvx && processor_runs(KernelSet::avx2),
                              kBuiltWithAvx && processor_runs(KernelSet::avx512)};
  static_assert(std::size(runs) == std::size(kKernelSets));
  return runs[static_cast<int>(set)];
}

const FitKernels& kernels_of(KernelSet set) {
#if defined(SKINSPEC_FIT_AVX_KERNELS) && defined(__x86_64__)
  if (set == KernelSet::avx2) return avx2_fit_kernels;
  if (set == KernelSet::avx512) return avx512_fit_kernels;
#endif
  (void)set;
  return generic_fit_kernels;
}

const FitKernels& fit_kernels() { return *active().load(std::memory_order_relaxed); }

KernelSet active_kernel_set() {
  for (const KernelSet set : kKernelSets)
    if (kernel_set_available(set) && &fit_kernels() == &kernels_of(set)) return set;
  return KernelSet::generic;
}

void use_kernel_set(KernelSet set) {
  if (kernel_set_available(set)) active().store(&kernels_of(set), std::memory_order_relaxed);
}

}  // namespace skinspec::detail
