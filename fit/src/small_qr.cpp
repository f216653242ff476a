#include "small_qr.hpp"

#include <cmath>

namespace skinspec::detail {

namespace {

constexpr int kMaxColumns = 16;

double dot(const double* x, const double* y, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) sum += x[i] * y[i];
  return sum;
}

// The dot products of x with each of the `count` vectors y[0..count), n entries each, in one
// pass over the entries: four sums at a time run side by side instead of one after another,
// each still adding its terms in order, so each equals dot(x, y[c], n) exactly.
void dots(const double* x, double* const* y, int count, int n, double* out) {
  for (int c = 0; c < count; c += 4) {
    const int group = count - c < 4 ? count - c : 4;
    // Short groups repeat their last vector; the repeated sums are dropped.
    const double* y0 = y[c];
    const double* y1 = y[c + (group > 1 ? 1 : 0)];
    const double* y2 = y[c + (group > 2 ? 2 : group - 1)];
    const double* y3 = y[c + group - 1];
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
    for (int i = 0; i < n; ++i) {
      s0 += x[i] * y0[i];
      s1 += x[i] * y1[i];
      s2 += x[i] * y2[i];
      s3 += x[i] * y3[i];
    }
    const double sums[] = {s0, s1, s2, s3};
    for (int g = 0; g < group; ++g) out[c + g] = sums[g];
  }
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
