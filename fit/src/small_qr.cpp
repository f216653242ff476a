#include "small_qr.hpp"

#include <Eigen/Core>
#include <cmath>

namespace skinspec::detail {

namespace {

constexpr int kMaxColumns = 16;

// The dot products of x with each of the `count` vectors y[0..count), n entries each, by
// Eigen's vectorised reductions: several partial sums at once, rather than one sum whose every
// addition waits on the one before.
void dots(const double* x, double* const* y, int count, int n, double* out) {
  const Eigen::Map<const Eigen::VectorXd> v(x, n);
  for (int c = 0; c < count; ++c) out[c] = v.dot(Eigen::Map<const Eigen::VectorXd>(y[c], n));
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
    const double norm2 = Eigen::Map<const Eigen::VectorXd>(v, length).squaredNorm();
    if (norm2 == 0) continue;  // nothing to eliminate
    // The diagonal takes the sign opposite to v[0]'s, so that v[0] - diagonal does not cancel.
    const double diagonal = v[0] > 0 ? -std::sqrt(norm2) : std::sqrt(norm2);
    // The reflection I - 2 v v^T / |v|^2 with v = x - diagonal e1, |v|^2 = 2 (|x|^2 - x0 diagonal).
    const double half_v_norm2 = norm2 - v[0] * diagonal;
    v[0] -= diagonal;
    // The reflection applied to the columns right of j and to b.
    double* targets[kMaxColumns + 1];
    double products[kMaxColumns + 1];
    int count = 0;
    for (int l = j + 1; l < cols; ++l) targets[count++] = a + l * rows + j;
    targets[count++] = b + j;
    dots(v, targets, count, length, products);
    for (int t = 0; t < count; ++t) subtract(targets[t], products[t] / half_v_norm2, v, length);
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
