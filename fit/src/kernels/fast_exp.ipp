// exp and expm1 for the kernels (kernels.hpp), written out so that a loop over samples that
// calls them vectorises: libm's are calls the compiler cannot vectorise. Branch-free: Cody-Waite
// reduction x = n ln2 + r with |r| <= ln2 / 2, a Taylor polynomial in r, and 2^n made from n's
// bits. Included inside each kernel file's anonymous namespace, so it includes nothing.
//
// Accuracy (tests/fit_kernels_test.cpp checks it against std::exp and std::expm1):
// - exp: within 2 ulp (measured: 1 ulp) wherever the result is a normal double; 0 where it would
//   be below 2^-1021 (x < -707.7: subnormals are flushed, the model only ever needs them as 0);
//   +inf above 709.78; NaN stays NaN. fast_exp_of_negative likewise for x <= 0.
// - expm1: within 3 ulp (measured: 2 ulp) everywhere, exactly x for tiny x, -1 below -50, +inf
//   above 709.78; NaN stays NaN.

// The reduction: n = round(x / ln2) by adding and subtracting 1.5 * 2^52 (the sum's low bits
// hold n in two's complement, which gives 2^n below without a conversion to an integer), then
// r = x - n ln2 in two parts (ln2's high part has trailing zeros, so n * kLn2High is exact).
constexpr double kLog2e = 1.4426950408889634;
constexpr double kLn2High = 6.93147180369123816490e-01;
constexpr double kLn2Low = 1.90821492927058770002e-10;
constexpr double kRoundingShifter = 0x1.8p52;
// Where 2^(n - 1) stays a normal double and exp's result finite.
constexpr double kExpLowest = -707.7;
constexpr double kExpHighest = 709.782712893384;
// Below this expm1 is -1 to double precision (e^-50 < 2^-72).
constexpr double kExpm1Lowest = -50;
constexpr double kInfinity = __builtin_inf();

struct Reduced {
  double r;                  // x - n ln2, |r| <= ln2 / 2
  double half_power_of_two;  // 2^(n - 1): 2^n itself would overflow for x near kExpHighest
};

// x is clamped by the caller to [kExpLowest, kExpHighest] (or NaN).
inline Reduced reduce(double x) {
  const double shifted = x * kLog2e + kRoundingShifter;
  const double n = shifted - kRoundingShifter;
  const double r = (x - n * kLn2High) - n * kLn2Low;
  // The low 12 bits of shifted's bits are n mod 4096; (n - 1 + 1023) << 52 is 2^(n - 1)'s exponent field.
  const auto bits = __builtin_bit_cast(unsigned long long, shifted);
  return {r, __builtin_bit_cast(double, (bits + 1022ULL) << 52)};
}

// expm1(r) - r over r^2 for |r| <= ln2 / 2: Taylor's series to r^13, whose next term is below
// 2^-56 of the result. By Estrin's scheme (pairs of terms, then pairs of pairs, by powers of r
// squared) rather than Horner's: four multiply-adds deep instead of eleven, since the model's
// loops wait on their exponentials.
inline double expm1_tail(double r) {
  constexpr double c[] = {1.0 / 2,     1.0 / 6,      1.0 / 24,      1.0 / 120,      1.0 / 720,       1.0 / 5040,
                          1.0 / 40320, 1.0 / 362880, 1.0 / 3628800, 1.0 / 39916800, 1.0 / 479001600, 1.0 / 6227020800};
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const double p01 = c[0] + c[1] * r, p23 = c[2] + c[3] * r, p45 = c[4] + c[5] * r;
  const double p67 = c[6] + c[7] * r, p89 = c[8] + c[9] * r, p1011 = c[10] + c[11] * r;
  const double p0_3 = p01 + p23 * r2, p4_7 = p45 + p67 * r2, p8_11 = p89 + p1011 * r2;
  return (p0_3 + p4_7 * r4) + p8_11 * r8;
}

inline double clamp_to(double x, double lowest, double highest) {
  // Written so that NaN passes through: both comparisons are false.
  return x < lowest ? lowest : (x > highest ? highest : x);
}

// e^x for x already reduced, within the range it may be reduced from.
inline double exp_of_reduced(const Reduced& reduced) {
  const double r = reduced.r;
  const double exp_r = 1.0 + (r + r * r * expm1_tail(r));
  return exp_r * reduced.half_power_of_two * 2.0;
}

inline double fast_exp(double x) {
  const double y = exp_of_reduced(reduce(clamp_to(x, kExpLowest, kExpHighest)));
  return x < kExpLowest ? 0.0 : (x > kExpHighest ? kInfinity : y);
}

// fast_exp for x <= 0 (or NaN), as the model's optical depths and losses give it: one
// comparison serves both the clamp and the flush to 0, where fast_exp needs four for both ends.
inline double fast_exp_of_negative(double x) {
  const bool below = x < kExpLowest;
  const double y = exp_of_reduced(reduce(below ? kExpLowest : x));
  return below ? 0.0 : y;
}

inline double fast_expm1(double x) {
  const Reduced reduced = reduce(clamp_to(x, kExpm1Lowest, kExpHighest));
  const double r = reduced.r;
  const double expm1_r = r + r * r * expm1_tail(r);
  // e^x - 1 = 2^n expm1(r) + (2^n - 1), halved and doubled again (exactly) for 2^(n - 1); the
  // second sum is exact for small |n|, where the first term does not dominate.
  const double half = reduced.half_power_of_two;
  const double y = 2.0 * (half * expm1_r + (half - 0.5));
  return x < kExpm1Lowest ? -1.0 : (x > kExpHighest ? kInfinity : y);
}
