// SPDX-License-Identifier: MIT
// Bit-for-bit comparison of two runs (records, crossings, trajectories, hazard tables),
// shared by the Monte-Carlo and dda-run tests.
#pragma once
#include <gtest/gtest.h>

#include <cstring>

#include "talus/mc/realization.hpp"

namespace talus::mc::testing {

/// Same bits (NaN equals NaN: off-terrain heights are NaN).
inline bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
inline bool same_bits(const Vec3& a, const Vec3& b) {
  return same_bits(a.x(), b.x()) && same_bits(a.y(), b.y()) && same_bits(a.z(), b.z());
}

inline void expect_same_run(const RunData& a, const RunData& b) {
  ASSERT_EQ(a.records.size(), b.records.size());
  for (std::size_t k = 0; k < a.records.size(); ++k) EXPECT_EQ(a.records[k], b.records[k]) << "record " << k;
  ASSERT_EQ(a.crossings.size(), b.crossings.size());
  for (std::size_t k = 0; k < a.crossings.size(); ++k) {
    const Crossing &p = a.crossings[k], &q = b.crossings[k];
    EXPECT_TRUE(p.realization == q.realization && p.barrier == q.barrier && p.direction == q.direction &&
                same_bits(p.position, q.position) && same_bits(p.time, q.time) && same_bits(p.height, q.height) &&
                same_bits(p.velocity, q.velocity) && same_bits(p.kinetic_energy, q.kinetic_energy))
        << "crossing " << k;
  }
  ASSERT_EQ(a.trajectories.size(), b.trajectories.size());
  for (std::size_t k = 0; k < a.trajectories.size(); ++k) {
    const TrajectoryPoint &p = a.trajectories[k], &q = b.trajectories[k];
    EXPECT_TRUE(p.realization == q.realization && same_bits(p.sample.time, q.sample.time) &&
                same_bits(p.sample.position, q.sample.position) && same_bits(p.sample.velocity, q.sample.velocity) &&
                same_bits(p.sample.height, q.sample.height) && same_bits(p.sample.energy, q.sample.energy) &&
                same_bits(Vec3(p.sample.orientation.vec()), Vec3(q.sample.orientation.vec())) &&
                same_bits(p.sample.orientation.w(), q.sample.orientation.w()) &&
                same_bits(p.sample.angular_velocity, q.sample.angular_velocity) && p.sample.motion == q.sample.motion)
        << "trajectory point " << k;
  }
  const auto ta = a.hazard.table(), tb = b.hazard.table();
  EXPECT_EQ(ta.cell, tb.cell);
  EXPECT_EQ(ta.reach, tb.reach);
  EXPECT_EQ(ta.energy_zero, tb.energy_zero);
  EXPECT_EQ(ta.height_zero, tb.height_zero);
  EXPECT_EQ(ta.speed_max, tb.speed_max);
  EXPECT_EQ(ta.height_max, tb.height_max);
  EXPECT_EQ(ta.energy_cell, tb.energy_cell);
  EXPECT_EQ(ta.energy_index, tb.energy_index);
  EXPECT_EQ(ta.energy_count, tb.energy_count);
  EXPECT_EQ(ta.height_cell, tb.height_cell);
  EXPECT_EQ(ta.height_index, tb.height_index);
  EXPECT_EQ(ta.height_count, tb.height_count);
  EXPECT_EQ(ta.energy_max, tb.energy_max);
  EXPECT_EQ(ta.speed_zero, tb.speed_zero);
  EXPECT_EQ(ta.speed_cell, tb.speed_cell);
  EXPECT_EQ(ta.speed_index, tb.speed_index);
  EXPECT_EQ(ta.speed_count, tb.speed_count);
  EXPECT_EQ(ta.exact_cell, tb.exact_cell);
  EXPECT_EQ(ta.exact_energy, tb.exact_energy);
  EXPECT_EQ(ta.exact_height, tb.exact_height);
  EXPECT_EQ(ta.exact_speed, tb.exact_speed);
}

}  // namespace talus::mc::testing
