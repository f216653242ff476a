// Which kernel set runs (kernels.hpp): AVX2 where this build has it and the processor can run
// it, unless SKINSPEC_FIT_KERNELS=generic asks for the generic one (so that the tests check
// both on one machine).

#include "kernels.hpp"

#include <atomic>
#include <cstdlib>
#include <string_view>

namespace skinspec::detail {

namespace {

bool processor_has_avx2_and_fma() {
#if defined(SKINSPEC_FIT_AVX2_KERNELS) && defined(__x86_64__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

bool generic_asked_for() {
  const char* asked = std::getenv("SKINSPEC_FIT_KERNELS");
  return asked != nullptr && std::string_view(asked) == "generic";
}

std::atomic<const FitKernels*>& active() {
  static std::atomic<const FitKernels*> kernels{&kernels_of(
      kernel_set_available(KernelSet::avx2) && !generic_asked_for() ? KernelSet::avx2 : KernelSet::generic)};
  return kernels;
}

}  // namespace

bool kernel_set_available(KernelSet set) {
  static const bool has_avx2 = processor_has_avx2_and_fma();
  return set == KernelSet::generic || has_avx2;
}

const FitKernels& kernels_of(KernelSet set) {
#if defined(SKINSPEC_FIT_AVX2_KERNELS) && defined(__x86_64__)
  if (set == KernelSet::avx2) return avx2_fit_kernels;
#endif
  (void)set;
  return generic_fit_kernels;
}

const FitKernels& fit_kernels() { return *active().load(std::memory_order_relaxed); }

KernelSet active_kernel_set() { return &fit_kernels() == &generic_fit_kernels ? KernelSet::generic : KernelSet::avx2; }

void use_kernel_set(KernelSet set) {
  if (kernel_set_available(set)) active().store(&kernels_of(set), std::memory_order_relaxed);
}

}  // namespace skinspec::detail
