// The kernels (kernels.hpp) for x86-64 processors with AVX-512 (F, VL and DQ): the loops the
// compiler vectorises eight doubles at a time, the QR's explicit vectors four. The build compiles this file alone with
// those flags, and prefers 512-bit vectors (fit/CMakeLists.txt); it is isolated as avx2.cpp is, for the same reason,
// and the test fit_avx512_kernels_self_contained checks its object file with nm.

#if defined(__x86_64__)

#include "kernels.hpp"

namespace skinspec::detail {
namespace {

#include "fast_exp.ipp"
#include "model_kernels.ipp"
#include "qr_kernels.ipp"
#include "kernel_table.ipp"

}  // namespace

constinit const FitKernels avx512_fit_kernels = kernel_table("avx512");

}  // namespace skinspec::detail

#endif
