#include "talus/core/random.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

namespace talus::core {
namespace {

// Random123 known-answer vectors for Philox4x32-10 (tests/kat_vectors of that library).
TEST(Philox, KnownAnswers) {
  EXPECT_EQ(philox4x32_10({0, 0, 0, 0}, {0, 0}),
            (PhiloxCounter{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}));
  EXPECT_EQ(philox4x32_10({0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, {0xffffffffu, 0xffffffffu}),
            (PhiloxCounter{0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}));
  EXPECT_EQ(philox4x32_10({0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, {0xa4093822u, 0x299f31d0u}),
            (PhiloxCounter{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}));
}

TEST(DetMath, LogMatchesLibmWithinTwoUlp) {
  RandomStream s(7, Stream::bootstrap, 0);
  for (std::uint64_t k = 0; k < 20000; ++k) {
    const double x = std::ldexp(s.uniform(k) + 0.5, static_cast<int>(k % 200) - 100);
    const double expected = std::log(x);
    EXPECT_NEAR(detmath::log(x), expected, 2.0 * std::abs(expected) * 0x1.0p-52 + 1e-300) << x;
  }
  EXPECT_EQ(detmath::log(1.0), 0.0);
}

TEST(DetMath, SinCosMatchLibm) {
  for (int k = 0; k < 100000; ++k) {
    const double t = k / 100000.0;
    double s = 0.0, c = 0.0;
    detmath::sincos_2pi(t, s, c);
    // The libm reference rounds its argument 2πt (up to half an ulp of 2π ≈ 4.4e-16),
    // so agreement is to about 1e-15, not to the last bit.
    EXPECT_NEAR(s, std::sin(2.0 * M_PI * t), 1e-15) << t;
    EXPECT_NEAR(c, std::cos(2.0 * M_PI * t), 1e-15) << t;
  }
}

TEST(RandomStream, IsPureFunctionOfSeedPurposeRealizationIndex) {
  const RandomStream a(42, Stream::terrain_roughness, 3);
  const RandomStream b(42, Stream::terrain_roughness, 3);
  for (std::uint64_t k = 0; k < 1000; ++k) EXPECT_EQ(a.normal(k), b.normal(k));
  EXPECT_NE(a.normal(0), RandomStream(43, Stream::terrain_roughness, 3).normal(0));
  EXPECT_NE(a.normal(0), RandomStream(42, Stream::impact, 3).normal(0));
  EXPECT_NE(a.normal(0), RandomStream(42, Stream::terrain_roughness, 4).normal(0));
}

TEST(RandomStream, BulkNormalsEqualSingleDraws) {
  const RandomStream s(9, Stream::terrain_roughness, 1);
  for (std::uint64_t first : {0u, 1u, 6u, 7u}) {
    for (std::uint64_t n : {0u, 1u, 2u, 5u, 8u}) {
      std::vector<double> bulk(n);
      s.normals(first, bulk.data(), n);
      for (std::uint64_t j = 0; j < n; ++j) EXPECT_EQ(bulk[j], s.normal(first + j));
    }
  }
}

// Golden values: any change of the mapping from (seed, stream, index) to numbers changes
// every stored realization, so it must be deliberate.
TEST(RandomStream, GoldenValues) {
  const RandomStream s(2026, Stream::terrain_roughness, 0);
  std::uint64_t hash = 1469598103934665603ull;
  for (std::uint64_t k = 0; k < 4096; ++k) {
    const double v = s.normal(k);
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    hash = (hash ^ bits) * 1099511628211ull;
  }
  EXPECT_EQ(hash, 13138502471731873805ull);
}

TEST(RandomStream, MomentsOfUniformAndNormal) {
  const RandomStream s(123, Stream::impact, 0);
  const int n = 400000;
  double su = 0, su2 = 0, sn = 0, sn2 = 0, sn4 = 0;
  for (int k = 0; k < n; ++k) {
    const double u = s.uniform(static_cast<std::uint64_t>(k));
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    su += u;
    su2 += u * u;
    const double z = s.normal(static_cast<std::uint64_t>(k));
    sn += z;
    sn2 += z * z;
    sn4 += z * z * z * z;
  }
  // Five standard errors of each sample moment.
  EXPECT_NEAR(su / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(su2 / n, 1.0 / 3, 5 * std::sqrt(4.0 / 45 / n));
  EXPECT_NEAR(sn / n, 0.0, 5 * std::sqrt(1.0 / n));
  EXPECT_NEAR(sn2 / n, 1.0, 5 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sn4 / n, 3.0, 5 * std::sqrt(96.0 / n));
}

TEST(RandomSequence, CountsDraws) {
  RandomSequence seq(RandomStream(5, Stream::impact, 2));
  const double a = seq.uniform();
  const double b = seq.normal();
  EXPECT_EQ(seq.draws(), 2u);
  EXPECT_EQ(a, RandomStream(5, Stream::impact, 2).uniform(0));
  EXPECT_EQ(b, RandomStream(5, Stream::impact, 2).normal(1));
}

}  // namespace
}  // namespace talus::core
