// SPDX-License-Identifier: MIT
#include "talus/geometry/box_tree.hpp"

#include <algorithm>
#include <numeric>

namespace talus::geometry {

void BoxTree::build(const std::vector<Aabb>& boxes) {
  nodes_.clear();
  items_.clear();
  if (boxes.empty()) return;
  const std::size_t n = boxes.size();
  std::vector<Vec3> centers(n);
  for (std::size_t i = 0; i < n; ++i) centers[i] = boxes[i].center();
  items_.resize(n);
  std::iota(items_.begin(), items_.end(), 0);
  nodes_.reserve(2 * (n / static_cast<std::size_t>(kLeafSize)) + 2);
  nodes_.push_back({});

  struct Work {
    std::int32_t node, begin, end;
  };
  std::vector<Work> work{{0, 0, static_cast<std::int32_t>(n)}};
  while (!work.empty()) {
    const Work w = work.back();
    work.pop_back();
    Aabb box;
    Aabb spread;
    for (std::int32_t k = w.begin; k < w.end; ++k) {
      const auto item = static_cast<std::size_t>(items_[static_cast<std::size_t>(k)]);
      box.add(boxes[item]);
      spread.add(centers[item]);
    }
    nodes_[static_cast<std::size_t>(w.node)].box = box;
    if (w.end - w.begin <= kLeafSize) {
      nodes_[static_cast<std::size_t>(w.node)].first = w.begin;
      nodes_[static_cast<std::size_t>(w.node)].count = w.end - w.begin;
      continue;
    }
    int axis = 0;
    const Vec3 extent = spread.extent();
    if (extent.y() > extent[axis]) axis = 1;
    if (extent.z() > extent[axis]) axis = 2;
    const std::int32_t mid = w.begin + (w.end - w.begin) / 2;
    // Ties broken by item id: the tree depends only on the input, never on the library's
    // partition algorithm.
    std::nth_element(items_.begin() + w.begin, items_.begin() + mid, items_.begin() + w.end,
                     [&](std::int32_t a, std::int32_t b) {
                       const double ca = centers[static_cast<std::size_t>(a)][axis];
                       const double cb = centers[static_cast<std::size_t>(b)][axis];
                       return ca < cb || (ca == cb && a < b);
                     });
    const auto left = static_cast<std::int32_t>(nodes_.size());
    nodes_[static_cast<std::size_t>(w.node)].first = left;
    nodes_[static_cast<std::size_t>(w.node)].count = 0;
    nodes_.push_back({});
    nodes_.push_back({});
    work.push_back({left, w.begin, mid});
    work.push_back({left + 1, mid, w.end});
  }
}

}  // namespace talus::geometry
