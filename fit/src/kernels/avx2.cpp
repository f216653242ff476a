// The kernels (kernels.hpp) for x86-64 processors with AVX2 and FMA: four doubles at a time and
// fused multiply-adds. The build compiles this file alone with -mavx2 -mfma (fit/CMakeLists.txt),
// so nothing in it may be defined by another file as well: a weak definition (an inline or
// template function of Eigen or the standard library) compiled here could be the copy the linker
// keeps for every caller, and run on a processor without AVX. It includes only kernels.hpp and
// the kernels, all of which have internal linkage; the test fit_avx2_kernels_self_contained
// checks its object file with nm.

#if defined(__x86_64__)

#include "kernels.hpp"

namespace skinspec::detail {
namespace {

#include "fast_exp.ipp"
#include "model_kernels.ipp"
#include "qr_kernels.ipp"
#include "kernel_table.ipp"

}  // namespace

constinit const FitKernels avx2_fit_kernels = kernel_table("avx2");

}  // namespace skinspec::detail

#endif
