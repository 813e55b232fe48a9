// SPDX-License-Identifier: MIT
#include "talus/geometry/box_tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

namespace talus::geometry {
namespace {

std::vector<Aabb> random_boxes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Aabb> boxes;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 c(u(rng), u(rng), u(rng));
    const Vec3 h = 0.03 * Vec3(u(rng), u(rng), u(rng));
    boxes.push_back(Aabb{c - h, c + h});
  }
  return boxes;
}

// Every query finds exactly the items a scan of the boxes finds (the tree's leaves list
// their items, and a leaf's items are tested here as a caller would test them).
TEST(GeometryBoxTree, QueriesMatchAScan) {
  for (const std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{5}, std::size_t{1000}}) {
    const std::vector<Aabb> boxes = random_boxes(n, 11);
    BoxTree tree;
    tree.build(boxes);
    EXPECT_EQ(tree.empty(), n == 0);
    std::vector<std::int32_t> all = tree.items();
    std::sort(all.begin(), all.end());
    for (std::size_t k = 0; k < n; ++k) ASSERT_EQ(all[k], static_cast<std::int32_t>(k));
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int q = 0; q < 50; ++q) {
      const Vec3 c(u(rng), u(rng), u(rng));
      const Aabb query{c - Vec3::Constant(0.1), c + Vec3::Constant(0.1)};
      std::vector<std::int32_t> found, expected;
      tree.overlapping(query, [&](std::int32_t i) {
        if (boxes[static_cast<std::size_t>(i)].overlaps(query)) found.push_back(i);
      });
      for (std::size_t k = 0; k < n; ++k)
        if (boxes[k].overlaps(query)) expected.push_back(static_cast<std::int32_t>(k));
      std::sort(found.begin(), found.end());
      EXPECT_EQ(found, expected);
      // Vertical: boxes over (x, y) reaching above z_floor.
      const double x = c.x(), y = c.y(), floor = 0.5;
      found.clear();
      expected.clear();
      const auto hit = [&](const Aabb& b) {
        return x >= b.lo.x() && x <= b.hi.x() && y >= b.lo.y() && y <= b.hi.y() && b.hi.z() >= floor;
      };
      tree.vertical(x, y, [&] { return floor; }, [&](std::int32_t i) {
        if (hit(boxes[static_cast<std::size_t>(i)])) found.push_back(i);
      });
      for (std::size_t k = 0; k < n; ++k)
        if (hit(boxes[k])) expected.push_back(static_cast<std::int32_t>(k));
      std::sort(found.begin(), found.end());
      EXPECT_EQ(found, expected);
      // The branch-and-bound maximum of the distance from c to the boxes' far corners.
      const auto value = [&](std::int32_t i) {
        const Aabb& b = boxes[static_cast<std::size_t>(i)];
        return ((b.center() - c).cwiseAbs() + 0.5 * b.extent()).norm();
      };
      const auto bound = [&](const Aabb& b) { return ((b.center() - c).cwiseAbs() + 0.5 * b.extent()).norm(); };
      double scan = -1.0;
      for (std::size_t k = 0; k < n; ++k) scan = std::max(scan, value(static_cast<std::int32_t>(k)));
      EXPECT_EQ(tree.maximum(bound, value, -1.0), scan);
    }
  }
}

// The tree depends on the boxes only: equal centres are split by item id.
TEST(GeometryBoxTree, BuildIsDeterministicWithTies) {
  std::vector<Aabb> boxes(100, Aabb{Vec3::Zero(), Vec3::Ones()});
  BoxTree a, b;
  a.build(boxes);
  b.build(boxes);
  EXPECT_EQ(a.items(), b.items());
  ASSERT_EQ(a.nodes().size(), b.nodes().size());
  for (std::size_t k = 0; k < a.nodes().size(); ++k) {
    EXPECT_EQ(a.nodes()[k].first, b.nodes()[k].first);
    EXPECT_EQ(a.nodes()[k].count, b.nodes()[k].count);
  }
  std::int32_t leaves = 0;
  for (const BoxTree::Node& node : a.nodes()) {
    EXPECT_LE(node.count, BoxTree::kLeafSize);
    leaves += node.count;
  }
  EXPECT_EQ(leaves, 100);
}

}  // namespace
}  // namespace talus::geometry
