// SPDX-License-Identifier: MIT
// The contact states carried from one step to the next (contact_law.hpp, carry_contacts).
#include <algorithm>
#include <limits>
#include <utility>

#include "contact_law.hpp"

namespace talus::dda::detail {

namespace {

// The previous contacts of the same kind and block feature as a contact, in their order:
// all of them for a few contacts, or a range of them sorted by (kind, block feature,
// order) for many (a detailed block carries hundreds; the pairwise scan was quadratic).
class SameFeature {
 public:
  SameFeature(const std::vector<Contact>& previous, std::size_t now) : previous_(previous) {
    sorted_ = previous.size() * now > 256;
    if (!sorted_) return;
    keyed_.clear();
    for (std::size_t i = 0; i < previous.size(); ++i) keyed_.emplace_back(key(previous[i]), static_cast<std::int32_t>(i));
    std::sort(keyed_.begin(), keyed_.end());
  }
  // Calls visit(old) for each, in order, until it returns false.
  template <class Visit>
  void each(const Contact& c, const Visit& visit) const {
    if (!sorted_) {
      for (const Contact& old : previous_)
        if (old.kind == c.kind && old.block_feature == c.block_feature && !visit(old)) return;
      return;
    }
    const std::uint64_t k = key(c);
    for (auto it = std::lower_bound(keyed_.begin(), keyed_.end(), std::make_pair(k, std::int32_t{-1}));
         it != keyed_.end() && it->first == k; ++it)
      if (!visit(previous_[static_cast<std::size_t>(it->second)])) return;
  }

 private:
  static std::uint64_t key(const Contact& c) {
    return (static_cast<std::uint64_t>(c.kind) << 32) | static_cast<std::uint32_t>(c.block_feature);
  }
  const std::vector<Contact>& previous_;
  bool sorted_ = false;
  inline static thread_local std::vector<std::pair<std::uint64_t, std::int32_t>> keyed_;
};

// Takes the state of `old` into `c`, springs resumed where the last solve left them: the
// exact rotation puts points deeper than the step predicted, and that extra depth must not
// push out.
void carry_one(const Contact& old, Contact& c, const Pose& pose, double friction, double shear_stiffness,
               double radius) {
  c.mode = old.mode;
  c.resume = old.resume;
  c.anchored = old.anchored;
  c.body_anchor = old.body_anchor;
  c.ground_anchor = old.ground_anchor;
  c.slip_direction = old.slip_direction;
  c.normal_force = old.normal_force;
  c.anchor_force = old.anchor_force;
  double offset = old.gap_offset;
  const double extra = old.spring_gap - (c.gap - offset);
  if (extra > 1e-3 * -old.spring_gap && extra > 1e-9 * radius) offset = c.gap - old.spring_gap;
  c.gap_offset = c.gap > offset ? std::min(0.0, c.gap) : offset;
  if (c.anchored) {
    const Vec3 xa = pose.centre + pose.map * c.body_anchor;
    const Vec3 s_raw = xa - c.ground_anchor;
    const Vec3 st = s_raw - c.normal * c.normal.dot(s_raw);
    const double allowed = std::min(friction * c.anchor_force, old.spring_shear) / shear_stiffness;
    const double stretch = st.norm();
    if (stretch > allowed) c.ground_anchor += st * (1.0 - allowed / stretch);
    // Rolling over the smooth surface the material point under the contact changes; the
    // anchors follow the contact point and keep the shear stretch.
    if (c.rolling) {
      const Vec3 kept = pose.centre + pose.map * c.body_anchor - c.ground_anchor;
      c.body_anchor = pose.inverse_map * (c.point - pose.centre);
      c.ground_anchor = c.point - c.gap * c.normal - (kept - c.normal * c.normal.dot(kept));
    }
  }
}

}  // namespace

bool carry_contacts(const std::vector<Contact>& previous, std::vector<Contact>& now, const Pose& pose,
                    double friction, double shear_stiffness, double fresh_depth, double radius,
                    std::vector<std::uint8_t>* matched) {
  const SameFeature same(previous, now.size());
  std::erase_if(now, [&](const Contact& c) {
    if (c.kind != ContactKind::edge_edge || c.gap >= -fresh_depth) return false;
    bool carried = false;
    same.each(c, [&](const Contact& old) {
      carried = old.terrain_feature == c.terrain_feature;
      return !carried;
    });
    return !carried;
  });
  if (matched != nullptr) matched->assign(now.size(), 0);
  thread_local std::vector<std::uint8_t> used, rolled;
  used.assign(previous.size(), 0);
  rolled.assign(previous.size(), 0);
  const auto take = [&](std::size_t i, const Contact& old) {
    if (matched != nullptr) (*matched)[i] = 1;
    used[static_cast<std::size_t>(&old - previous.data())] = 1;
    carry_one(old, now[i], pose, friction, shear_stiffness, radius);
  };
  // A contact rolling over the smooth surface passes from vertex to vertex as the support
  // moves: a rolling contact takes the state of its own feature's, else of the nearest
  // rolling contact of the last step on the same plane (or crest); the vertex it left
  // keeps none.
  for (std::size_t i = 0; i < now.size(); ++i) {
    Contact& c = now[i];
    if (!c.rolling) continue;
    c.gap_offset = std::min(c.gap, 0.0);
    // The same crest, or for a vertex contact the same plane.
    const auto same_ground = [&](const Contact& old) {
      return old.terrain_feature == c.terrain_feature ||
             (c.kind != ContactKind::vertex_ridge && old.normal.dot(c.normal) > 1.0 - 1e-12);
    };
    const Contact* match = nullptr;
    same.each(c, [&](const Contact& old) {
      if (!same_ground(old)) return true;
      match = &old;
      return false;
    });
    double nearest = std::numeric_limits<double>::infinity();
    if (match == nullptr)
      for (const Contact& old : previous) {
        if (used[static_cast<std::size_t>(&old - previous.data())] != 0 || !old.rolling || old.kind != c.kind ||
            !same_ground(old))
          continue;
        const double d = (old.point - c.point).squaredNorm();
        if (d < nearest) {
          nearest = d;
          match = &old;
        }
      }
    if (match == nullptr) continue;
    rolled[static_cast<std::size_t>(match - previous.data())] = 1;
    take(i, *match);
  }
  for (std::size_t i = 0; i < now.size(); ++i) {
    Contact& c = now[i];
    if (c.rolling) continue;
    c.gap_offset = std::min(c.gap, 0.0);
    const Contact* match = nullptr;
    same.each(c, [&](const Contact& old) {
      if (rolled[static_cast<std::size_t>(&old - previous.data())] != 0) return true;
      if (old.terrain_feature == c.terrain_feature) {
        match = &old;
        return false;
      }
      if (c.kind == ContactKind::vertex_face && old.normal.dot(c.normal) > 1.0 - 1e-12) match = &old;
      return true;
    });
    if (match != nullptr) take(i, *match);
  }
  return std::all_of(used.begin(), used.end(), [](std::uint8_t u) { return u != 0; });
}

}  // namespace talus::dda::detail
