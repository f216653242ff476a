// The fit's kernels (kernels.hpp) for each of Highway's targets, and the choice between them.
// Highway compiles this file once per target (foreach_target.h includes it again for each);
// the kernels live in model_kernels.ipp, qr_kernels.ipp and search_kernels.ipp, included in each target's namespace.

// Targets left out: SSSE3 and AVX3_DL give doubles nothing over SSE4 and AVX3; SVE's sizeless
// vectors cannot be members of the kernels' structs (ARM keeps NEON, which every 64-bit ARM has).
#define HWY_DISABLED_TARGETS (HWY_SSSE3 | HWY_AVX3_DL | HWY_SVE | HWY_SVE2 | HWY_SVE_256 | HWY_SVE2_128)

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/kernels.cpp"
#include <hwy/foreach_target.h>  // before highway.h

#include <hwy/contrib/math/math-inl.h>
#include <hwy/highway.h>

#include <cstddef>

#include "kernels/kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace skinspec::detail::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The kernels have internal linkage, as the compiler then inlines their helpers freely.
namespace {
#include "kernels/model_kernels.ipp"
#include "kernels/qr_kernels.ipp"
#include "kernels/search_kernels.ipp"
}  // namespace

const FitKernels* kernel_table() {
  static constexpr FitKernels table{HWY_TARGET,     &reflectance,   &jacobian,       &blood_packing,
                                    &power_law,     &triangularize, &scaled_columns, &normal_matrix,
                                    &coarse_errors, &exp_of,        &expm1_of};
  return &table;
}

}  // namespace skinspec::detail::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <vector>

namespace skinspec::detail {

HWY_EXPORT(kernel_table);

namespace {

// Highway chooses the best target the processor runs; told to take each runnable target in
// turn as the only one (the way its own tests reach every target), it gives each its kernels.
// Done once, before any kernels run, and nothing else in the programs dispatches through Highway.
std::vector<const FitKernels*> list_runnable() {
  std::vector<const FitKernels*> runnable;
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    runnable.push_back(HWY_DYNAMIC_DISPATCH(kernel_table)());
  }
  hwy::SetSupportedTargetsForTest(0);
  return runnable;
}

const FitKernels* chosen() {
  const auto runnable = runnable_fit_kernels();
  if (const char* asked = std::getenv("SKINSPEC_FIT_KERNELS"))
    for (const FitKernels* kernels : runnable)
      if (kernels_name(*kernels) == asked) return kernels;
  return runnable.front();
}

std::atomic<const FitKernels*>& active() {
  static std::atomic<const FitKernels*> kernels{chosen()};
  return kernels;
}

}  // namespace

std::span<const FitKernels* const> runnable_fit_kernels() {
  static const std::vector<const FitKernels*> runnable = list_runnable();
  return runnable;
}

const FitKernels& fit_kernels() { return *active().load(std::memory_order_relaxed); }

std::string kernels_name(const FitKernels& kernels) {
  std::string name = hwy::TargetName(kernels.target);
  std::ranges::transform(name, name.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return name;
}

void use_fit_kernels(const FitKernels& kernels) { active().store(&kernels, std::memory_order_relaxed); }

}  // namespace skinspec::detail

#endif  // HWY_ONCE
