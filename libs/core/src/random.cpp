#include "talus/core/random.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

namespace talus::core {
namespace {

constexpr std::uint32_t kPhiloxM0 = 0xD2511F53u;
constexpr std::uint32_t kPhiloxM1 = 0xCD9E8D57u;
constexpr std::uint32_t kPhiloxW0 = 0x9E3779B9u;
constexpr std::uint32_t kPhiloxW1 = 0xBB67AE85u;

inline void mulhilo(std::uint32_t a, std::uint32_t b, std::uint32_t& hi, std::uint32_t& lo) {
  const std::uint64_t product = static_cast<std::uint64_t>(a) * b;
  hi = static_cast<std::uint32_t>(product >> 32);
  lo = static_cast<std::uint32_t>(product);
}

// Both Box–Muller outputs from one Philox block.
inline void normal_pair(const std::array<std::uint32_t, 4>& w, double& z0, double& z1) {
  // u1 in (0, 1]: never zero, so the logarithm is finite.
  const double u1 = 1.0 - to_unit_double(w[0], w[1]);
  const double u2 = to_unit_double(w[2], w[3]);
  const double radius = std::sqrt(-2.0 * detmath::log(u1));  // sqrt is IEEE-exact
  double s = 0.0;
  double c = 0.0;
  detmath::sincos_2pi(u2, s, c);
  z0 = radius * c;
  z1 = radius * s;
}

}  // namespace

PhiloxCounter philox4x32_10(PhiloxCounter ctr, PhiloxKey key) {
  for (int round = 0; round < 10; ++round) {
    std::uint32_t hi0 = 0, lo0 = 0, hi1 = 0, lo1 = 0;
    mulhilo(kPhiloxM0, ctr[0], hi0, lo0);
    mulhilo(kPhiloxM1, ctr[2], hi1, lo1);
    ctr = {hi1 ^ ctr[1] ^ key[0], lo1, hi0 ^ ctr[3] ^ key[1], lo0};
    key[0] += kPhiloxW0;
    key[1] += kPhiloxW1;
  }
  return ctr;
}

double RandomStream::uniform(std::uint64_t index) const {
  const auto w = block(index);
  return to_unit_double(w[0], w[1]);
}

double RandomStream::normal(std::uint64_t index) const {
  double z0 = 0.0, z1 = 0.0;
  normal_pair(block(index / 2), z0, z1);
  return (index % 2 == 0) ? z0 : z1;
}

void RandomStream::normals(std::uint64_t first, double* out, std::uint64_t n) const {
  std::uint64_t j = 0;
  if (n > 0 && first % 2 == 1) {
    out[j++] = normal(first);
  }
  for (; j + 1 < n; j += 2) {
    normal_pair(block((first + j) / 2), out[j], out[j + 1]);
  }
  if (j < n) out[j] = normal(first + j);
}

namespace detmath {

double log(double x) {
  if (!(x > 0.0)) return x == 0.0 ? -HUGE_VAL : std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(x)) return x;
  int exponent = 0;
  double m = std::frexp(x, &exponent);  // x = m 2^e, m in [0.5, 1); exact
  if (m < 0.70710678118654752440) {
    m *= 2.0;
    exponent -= 1;
  }
  // ln m = 2 atanh(s), s = (m-1)/(m+1), |s| <= 0.1716: the series converges fast.
  const double s = (m - 1.0) / (m + 1.0);
  const double s2 = s * s;
  double sum = 0.0;
  for (int k = 23; k >= 3; k -= 2) sum = (sum + 1.0 / k) * s2;
  const double ln_m = 2.0 * s * (1.0 + sum);
  // ln 2 split in a high part with trailing zero bits and a correction.
  constexpr double ln2_hi = 6.93147180369123816490e-01;
  constexpr double ln2_lo = 1.90821492927058770002e-10;
  const double e = exponent;
  return (e * ln2_hi + ln_m) + e * ln2_lo;
}

namespace {
// Taylor polynomials on |a| <= pi/4, to the 1e-17 level.
double sin_poly(double a) {
  const double a2 = a * a;
  double p = 0.0;
  for (int k = 19; k >= 3; k -= 2) p = (p + 1.0) * (-a2 / (k * (k - 1)));
  return a * (1.0 + p);
}
double cos_poly(double a) {
  const double a2 = a * a;
  double p = 0.0;
  for (int k = 20; k >= 2; k -= 2) p = (p + 1.0) * (-a2 / (k * (k - 1)));
  return 1.0 + p;
}
}  // namespace

void sincos_2pi(double t, double& s, double& c) {
  constexpr double two_pi = 6.28318530717958647692;
  // t*8 is exact for t in [0, 1); the octant and its remainder are exact too.
  const double t8 = t * 8.0;
  const int octant = static_cast<int>(t8);
  const double r = t8 - octant;  // in [0, 1)
  // Angle within the quarter period measured from the octant's nearest axis.
  const double a_lo = r * (two_pi / 8.0);
  const double a_hi = (1.0 - r) * (two_pi / 8.0);
  switch (octant & 7) {
    case 0: s = sin_poly(a_lo); c = cos_poly(a_lo); break;
    case 1: s = cos_poly(a_hi); c = sin_poly(a_hi); break;
    case 2: s = cos_poly(a_lo); c = -sin_poly(a_lo); break;
    case 3: s = sin_poly(a_hi); c = -cos_poly(a_hi); break;
    case 4: s = -sin_poly(a_lo); c = -cos_poly(a_lo); break;
    case 5: s = -cos_poly(a_hi); c = -sin_poly(a_hi); break;
    case 6: s = -cos_poly(a_lo); c = sin_poly(a_lo); break;
    default: s = -sin_poly(a_hi); c = cos_poly(a_hi); break;
  }
}

}  // namespace detmath
}  // namespace talus::core
