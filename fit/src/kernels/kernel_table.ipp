// The table of a kernel file's kernels (kernels.hpp, FitKernels), evaluated at compile time so
// that the table is constant-initialised. Included last inside each kernel file's anonymous
// namespace, so it includes nothing.

constexpr FitKernels kernel_table(const char* name) {
  return {name,           &reflectance,    &jacobian, &blood_packing,      &power_law,
          &triangularize, &scaled_columns, &exp_of,   &exp_of_negative_of, &expm1_of};
}
