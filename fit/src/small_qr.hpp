#pragma once
// Least squares by Householder QR for matrices of a few columns (private to fit/): plain loops
// over contiguous columns, which for the fit's at most 7 columns cost a fraction of a general
// library's blocked, size-agnostic code.

namespace skinspec::detail {

// Triangularises the rows x cols column-major matrix `a` (cols <= rows, cols <= 16) in place by Householder
// reflections, R in its upper triangle (what lies below it is scratch), and applies the same
// reflections to the vector `b` of `rows` entries: Q^T b.
void triangularize(double* a, int rows, int cols, double* b);

// Solves R x = b in place in `b` (cols entries) for R the upper triangle of the column-major
// `a` with `rows` rows. A zero on R's diagonal gives entries that are not finite.
void solve_upper(const double* a, int rows, int cols, double* b);

}  // namespace skinspec::detail
