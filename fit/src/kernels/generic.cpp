// The kernels (kernels.hpp) for any processor: on x86-64 the baseline's SSE2, two doubles at a
// time. The build compiles this file with -fno-math-errno and -fno-trapping-math, like the AVX
// files (fit/CMakeLists.txt), so that all three vectorise the same code.

#include "kernels.hpp"

namespace skinspec::detail {
namespace {

#include "fast_exp.ipp"
#include "model_kernels.ipp"
#include "qr_kernels.ipp"
#include "kernel_table.ipp"

}  // namespace

constinit const FitKernels generic_fit_kernels = kernel_table("generic");

}  // namespace skinspec::detail
