// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>

namespace talus::core {

/// Philox4x32-10 (Salmon et al. 2011, "Parallel random numbers: as easy as 1, 2, 3"):
/// a keyed bijection of a 128-bit counter. Verified against the Random123 known answers.
using PhiloxCounter = std::array<std::uint32_t, 4>;
using PhiloxKey = std::array<std::uint32_t, 2>;
PhiloxCounter philox4x32_10(PhiloxCounter counter, PhiloxKey key);

/// The purposes random numbers serve. Each has its own stream, so adding draws for one
/// purpose never shifts the draws of another. Values are part of the file formats:
/// never renumber.
enum class Stream : std::uint32_t {
  terrain_roughness = 1,  ///< grid-point elevation perturbations of a terrain realization
  terrain_diagonals = 2,  ///< random diagonal choice of the TRN cells
  release = 3,            ///< release position, orientation, velocity
  impact = 4,             ///< per-impact restitution, friction and lateral tilt draws
  block_shape = 5,        ///< random rock shapes, block-library sampling
  bootstrap = 6,          ///< statistical resampling
  calibration = 7,        ///< parameter proposals of a calibration (realization field = generation)
};

/// A counter-based random stream: draw k of stream (seed, purpose, realization) is a pure
/// function of those four numbers. Any thread, shard or tool regenerates the same value,
/// bit for bit, on every platform (the float mappings below use only IEEE-exact
/// arithmetic, never the C library's transcendental functions).
class RandomStream {
 public:
  RandomStream(std::uint64_t seed, Stream purpose, std::uint32_t realization)
      : key_{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)},
        realization_(realization), purpose_(static_cast<std::uint32_t>(purpose)) {}

  /// Four independent 32-bit words for block `index`.
  std::array<std::uint32_t, 4> block(std::uint64_t index) const {
    return philox4x32_10({static_cast<std::uint32_t>(index), static_cast<std::uint32_t>(index >> 32),
                          realization_, purpose_},
                         key_);
  }
  /// Uniform draw in [0, 1) with 53 random bits, the index-th of the stream.
  double uniform(std::uint64_t index) const;
  /// Standard normal draw N(0, 1), the index-th of the stream (Box–Muller on block
  /// index/2; even and odd indices are the cosine and sine halves of one pair).
  double normal(std::uint64_t index) const;
  /// Fills out[0..n) with normal(first + j); twice as fast as n calls to normal().
  void normals(std::uint64_t first, double* out, std::uint64_t n) const;

 private:
  PhiloxKey key_;
  std::uint32_t realization_;
  std::uint32_t purpose_;
};

/// Sequential reader of a RandomStream for code that needs "the next" draw, such as the
/// per-impact draws of one realization. Still fully determined by (seed, purpose,
/// realization) and the number of draws made.
class RandomSequence {
 public:
  explicit RandomSequence(RandomStream stream) : stream_(stream) {}
  double uniform() { return stream_.uniform(next_++); }
  double normal() { return stream_.normal(next_++); }
  std::uint64_t draws() const { return next_; }

 private:
  RandomStream stream_;
  std::uint64_t next_ = 0;
};

/// Maps two 32-bit words to a double in [0, 1) with 53 random bits.
inline double to_unit_double(std::uint32_t high, std::uint32_t low) {
  const std::uint64_t bits = (static_cast<std::uint64_t>(high) << 21) ^ (low >> 11);
  return static_cast<double>(bits & ((std::uint64_t{1} << 53) - 1)) * 0x1.0p-53;
}

namespace detmath {
/// Natural logarithm for x > 0, by argument reduction and an atanh series: within 2 ulp
/// of the correctly rounded value and identical on every IEEE-754 platform.
double log(double x);
/// sin(2πt) and cos(2πt) for t in [0, 1), by octant reduction and Taylor polynomials.
void sincos_2pi(double t, double& s, double& c);
}  // namespace detmath

}  // namespace talus::core
