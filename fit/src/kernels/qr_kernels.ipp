// small_qr.hpp's Householder triangularisation as a kernel (kernels.hpp). Each reflection takes
// two passes over its rows whatever the number of columns: one for every product it needs, one
// to apply it to every column right of it and to b. The passes work on as many rows at a time as
// a vector holds. Included inside kernels.cpp's per-target namespace, after model_kernels.ipp,
// so it includes nothing.

constexpr int kMaxQrColumns = 16;
// Columns a pass handles at once: each keeps a running sum in a register of its own.
constexpr int kColumnsPerPass = 8;

// How many of `count` columns the pass from column `first` handles.
constexpr int in_pass_of(int count, int first) {
  return count - first < kColumnsPerPass ? count - first : kColumnsPerPass;
}

using Tag = hn::ScalableTag<double>;
using Lanes = V<Tag>;

inline double sum_of(Lanes v) { return hn::GetLane(hn::SumOfLanes(Tag(), v)); }

// |v|^2 and v . y[t] for each of kCount columns y, over n rows.
template <int kCount>
void products(const double* v, const double* const* y, int n, double& norm2, double* out) {
  const Tag d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  Lanes squares = hn::Zero(d), sums[kCount];
  for (int t = 0; t < kCount; ++t) sums[t] = hn::Zero(d);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const Lanes x = hn::LoadU(d, v + i);
    squares = hn::MulAdd(x, x, squares);
    for (int t = 0; t < kCount; ++t) sums[t] = hn::MulAdd(x, hn::LoadU(d, y[t] + i), sums[t]);
  }
  double tail_squares = 0, tails[kCount] = {};
  for (; i < n; ++i) {
    tail_squares += v[i] * v[i];
    for (int t = 0; t < kCount; ++t) tails[t] += v[i] * y[t][i];
  }
  norm2 = sum_of(squares) + tail_squares;
  for (int t = 0; t < kCount; ++t) out[t] = sum_of(sums[t]) + tails[t];
}

// y[t] -= factor[t] v for each of kCount columns y, over n rows.
template <int kCount>
void subtract(const double* v, double* const* y, int n, const double* factor) {
  const Tag d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const Lanes x = hn::LoadU(d, v + i);
    for (int t = 0; t < kCount; ++t)
      hn::StoreU(hn::NegMulAdd(hn::Set(d, factor[t]), x, hn::LoadU(d, y[t] + i)), d, y[t] + i);
  }
  for (; i < n; ++i)
    for (int t = 0; t < kCount; ++t) y[t][i] -= factor[t] * v[i];
}

// The two passes for `count` columns (1 to kColumnsPerPass), each with its number of
// registers known.
template <int kCount = kColumnsPerPass>
void products_of(int count, const double* v, const double* const* y, int n, double& norm2, double* out) {
  if constexpr (kCount > 1)
    if (count < kCount) return products_of<kCount - 1>(count, v, y, n, norm2, out);
  products<kCount>(v, y, n, norm2, out);
}

template <int kCount = kColumnsPerPass>
void subtract_from(int count, const double* v, double* const* y, int n, const double* factor) {
  if constexpr (kCount > 1)
    if (count < kCount) return subtract_from<kCount - 1>(count, v, y, n, factor);
  subtract<kCount>(v, y, n, factor);
}

void triangularize(double* a, int rows, int cols, double* b) {
  for (int j = 0; j < cols; ++j) {
    double* v = a + j * rows + j;  // column j from the diagonal down, turned into the reflection
    const int length = rows - j;
    // The columns right of j and b, from row j down: what the reflection applies to.
    double* targets[kMaxQrColumns + 1];
    double products[kMaxQrColumns + 1];
    int count = 0;
    for (int l = j + 1; l < cols; ++l) targets[count++] = a + l * rows + j;
    targets[count++] = b + j;
    double norm2 = 0;
    for (int first = 0; first < count; first += kColumnsPerPass) {
      const int in_pass = in_pass_of(count, first);
      products_of(in_pass, v, targets + first, length, norm2, products + first);
    }
    if (norm2 == 0) continue;  // nothing to eliminate
    // The diagonal takes the sign opposite to v[0]'s, so that v[0] - diagonal does not cancel.
    const double diagonal = v[0] > 0 ? -__builtin_sqrt(norm2) : __builtin_sqrt(norm2);
    // The reflection I - 2 v v^T / |v|^2 with v = x - diagonal e1, |v|^2 = 2 (|x|^2 - x0 diagonal);
    // the products were taken with x, and v . y = x . y - diagonal y0.
    const double half_v_norm2 = norm2 - v[0] * diagonal;
    v[0] -= diagonal;
    double factors[kMaxQrColumns + 1];
    for (int t = 0; t < count; ++t) factors[t] = (products[t] - diagonal * targets[t][0]) / half_v_norm2;
    for (int first = 0; first < count; first += kColumnsPerPass) {
      const int in_pass = in_pass_of(count, first);
      subtract_from(in_pass, v, targets + first, length, factors + first);
    }
    v[0] = diagonal;
  }
}

// ScaledColumnsArgs's columns, kCount at a time in one pass over the rows: each keeps its two
// sums in registers of their own, so that the sums' additions do not wait on one another.
template <int kCount>
void scale_columns(const ScaledColumnsArgs& in, int first) {
  const double* column[kCount];
  double* out[kCount];
  for (int c = 0; c < kCount; ++c) {
    column[c] = in.jacobian + static_cast<long>(in.columns[first + c]) * in.rows;
    out[c] = in.out + static_cast<long>(first + c) * in.out_rows;
  }
  const Tag d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  Lanes squares[kCount], products[kCount];
  for (int c = 0; c < kCount; ++c) squares[c] = hn::Zero(d), products[c] = hn::Zero(d);
  int i = 0;
  for (; i + lanes <= in.rows; i += lanes) {
    const Lanes r = hn::LoadU(d, in.residuals + i);
    for (int c = 0; c < kCount; ++c) {
      const Lanes x = hn::LoadU(d, column[c] + i), y = hn::Set(d, in.scales[first + c]) * x;
      hn::StoreU(y, d, out[c] + i);
      squares[c] = hn::MulAdd(y, y, squares[c]);
      products[c] = hn::MulAdd(x, r, products[c]);
    }
  }
  for (int c = 0; c < kCount; ++c) {
    double tail_squares = 0, tail_products = 0;
    for (int row = i; row < in.rows; ++row) {
      const double y = in.scales[first + c] * column[c][row];
      out[c][row] = y;
      tail_squares += y * y;
      tail_products += column[c][row] * in.residuals[row];
    }
    for (int row = in.rows; row < in.out_rows; ++row) out[c][row] = 0;
    in.squared_norms[first + c] = sum_of(squares[c]) + tail_squares;
    in.products[first + c] = sum_of(products[c]) + tail_products;
  }
}

template <int kCount = kColumnsPerPass>
void scale_columns_of(int count, const ScaledColumnsArgs& in, int first) {
  if constexpr (kCount > 1)
    if (count < kCount) return scale_columns_of<kCount - 1>(count, in, first);
  scale_columns<kCount>(in, first);
}

// Each column's products with itself and the columns right of it, in one pass over the rows
// (products() above).
void normal_matrix(const NormalMatrixArgs& in) {
  const auto column = [&](int c) { return in.jacobian + static_cast<long>(in.columns[c]) * in.rows; };
  const auto at = [&](int a, int b) -> double& { return in.out[static_cast<long>(b) * in.count + a]; };
  for (int a = 0; a < in.count; ++a) {
    const double* v = column(a);
    const double* right[kMaxQrColumns];
    double found[kMaxQrColumns];
    int count = 0;
    for (int b = a + 1; b < in.count; ++b) right[count++] = column(b);
    if (count == 0) right[count++] = v;  // the last column: its own norm is all that is wanted
    double norm2 = 0;
    for (int first = 0; first < count; first += kColumnsPerPass)
      products_of(in_pass_of(count, first), v, right + first, in.rows, norm2, found + first);
    at(a, a) = norm2;
    for (int b = a + 1; b < in.count; ++b) at(a, b) = at(b, a) = found[b - a - 1];
  }
}

void scaled_columns(const ScaledColumnsArgs& in) {
  for (int first = 0; first < in.count; first += kColumnsPerPass) {
    const int in_pass = in_pass_of(in.count, first);
    scale_columns_of(in_pass, in, first);
  }
}
