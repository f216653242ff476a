#include "small_qr.hpp"

#include "kernels/kernels.hpp"

namespace skinspec::detail {

// The reflections' loops are kernels (kernels/qr_kernels.ipp), vectorised for the processor.
void triangularize(double* a, int rows, int cols, double* b) { fit_kernels().triangularize(a, rows, cols, b); }

void solve_upper(const double* a, int rows, int cols, double* b) {
  for (int i = cols - 1; i >= 0; --i) {
    double sum = b[i];
    for (int l = i + 1; l < cols; ++l) sum -= a[l * rows + i] * b[l];
    b[i] = sum / a[i * rows + i];
  }
}

}  // namespace skinspec::detail
