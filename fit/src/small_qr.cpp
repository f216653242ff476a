#include "small_qr.hpp"

#include <cmath>

namespace skinspec::detail {

namespace {

double dot(const double* x, const double* y, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += x[i] * y[i];
  return sum;
}

// y -= factor * v over n entries.
void subtract(double* y, double factor, const double* v, int n) {
  for (int i = 0; i < n; ++i) y[i] -= factor * v[i];
}

}  // namespace

void triangularize(double* a, int rows, int cols, double* b) {
  for (int j = 0; j < cols; ++j) {
    double* v = a + j * rows + j;  // column j from the diagonal down, turned into the reflection
    const int length = rows - j;
    const double norm2 = dot(v, v, length);
    if (norm2 == 0) continue;  // nothing to eliminate
    // The diagonal takes the sign opposite to v[0]'s, so that v[0] - diagonal does not cancel.
    const double diagonal = v[0] > 0 ? -std::sqrt(norm2) : std::sqrt(norm2);
    // The reflection I - 2 v v^T / |v|^2 with v = x - diagonal e1, |v|^2 = 2 (|x|^2 - x0 diagonal).
    const double half_v_norm2 = norm2 - v[0] * diagonal;
    v[0] -= diagonal;
    for (int l = j + 1; l < cols; ++l) {
      double* column = a + l * rows + j;
      subtract(column, dot(v, column, length) / half_v_norm2, v, length);
    }
    subtract(b + j, dot(v, b + j, length) / half_v_norm2, v, length);
    v[0] = diagonal;
  }
}

void solve_upper(const double* a, int rows, int cols, double* b) {
  for (int i = cols - 1; i >= 0; --i) {
    double sum = b[i];
    for (int l = i + 1; l < cols; ++l) sum -= a[l * rows + i] * b[l];
    b[i] = sum / a[i * rows + i];
  }
}

}  // namespace skinspec::detail
