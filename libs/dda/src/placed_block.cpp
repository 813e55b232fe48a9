// SPDX-License-Identifier: MIT
// The block at a pose, as the contact search and the step control see it (contacts.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "broad_phase.hpp"

namespace talus::dda::detail {

namespace {

// How far (m, times the block's radius) a detailed block may move before its box is
// computed afresh rather than widened from the last one (PlacedBlock).
constexpr double kBoxReuse = 0.02;

}  // namespace


PlacedBlock::PlacedBlock(const Model& model, const Pose& pose, std::vector<Vec3>& storage, bool scan,
                         BlockBox* reuse)
    : model_(&model), pose_(&pose), world_(&storage) {
  if (model.index == nullptr || scan) {
    storage.resize(model.vertices.size());
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (std::size_t i = 0; i < model.vertices.size(); ++i) {
      const Vec3 p = world_point(pose, model.vertices[i]);
      storage[i] = p;
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], p[k]);
        hi[k] = std::max(hi[k], p[k]);
      }
    }
    box_ = geometry::Aabb{lo, hi};
    return;
  }
  index_ = model.index.get();
  abs_inverse_ = pose.inverse_map.cwiseAbs();
  const Mat3 abs_map = pose.map.cwiseAbs();
  // centre + F·r rounds by a few ulps of |centre| + |F|·|r|, |r| ≤ radius.
  round_off_ = kRound * (pose.centre.cwiseAbs().maxCoeff() + model.radius * abs_map.rowwise().sum().maxCoeff());
  // ‖F⁻¹‖₂ = 1/σ_min(F), generously.
  inverse_stretch_ = norm_bound(pose.inverse_map, pose.rigid);
  if (reuse != nullptr && reuse->model == &model) {
    // A vertex has moved by at most |Δcentre| + ‖ΔF‖·|r| since (map_change bounds the
    // spectral norm), plus the round-off of its two world positions.
    const double moved =
        (pose.centre - reuse->centre).norm() + map_change(pose, reuse->map, reuse->rigid) * model.radius;
    const double slack = 2.0 * round_off_ + 1e-9 * (pose.centre.cwiseAbs().maxCoeff() + model.radius);
    if (moved <= kBoxReuse * model.radius) {
      box_ = reuse->box.inflated(moved + slack);
      return;
    }
  }
  // The box's faces are the extreme vertices along each axis: a climb of the vertex graph
  // on a convex block (widened by twice a vertex's round-off), else branch and bound over
  // the tree.
  if (!index_->climb.empty()) {
    const double slack = 2.0 * round_off_;
    for (int k = 0; k < 3; ++k) {
      const Vec3 row = pose.map.row(k).transpose();
      const std::int32_t hi = index_->climb.farthest(model.vertices, row);
      const std::int32_t lo = index_->climb.farthest(model.vertices, -row);
      box_.hi[k] = world_point(pose, model.vertices[static_cast<std::size_t>(hi)])[k] + slack;
      box_.lo[k] = world_point(pose, model.vertices[static_cast<std::size_t>(lo)])[k] - slack;
    }
    if (reuse != nullptr) *reuse = BlockBox{&model, pose.centre, pose.map, box_, pose.rigid};
    return;
  }
  for (int k = 0; k < 3; ++k) {
    const Vec3 row = pose.map.row(k).transpose();
    const Vec3 abs_row = abs_map.row(k).transpose();
    const double centre = pose.centre[k];
    const auto coordinate = [&](std::int32_t i) {
      return world_point(pose, model.vertices[static_cast<std::size_t>(i)])[k];
    };
    box_.hi[k] = index_->vertices.maximum(
        [&](const geometry::Aabb& b) {
          return centre + row.dot(b.center()) + abs_row.dot(0.5 * b.extent()) + round_off_;
        },
        coordinate);
    box_.lo[k] = -index_->vertices.maximum(
        [&](const geometry::Aabb& b) {
          return -centre - row.dot(b.center()) + abs_row.dot(0.5 * b.extent()) + round_off_;
        },
        [&](std::int32_t i) { return -coordinate(i); });
  }
  if (reuse != nullptr) *reuse = BlockBox{&model, pose.centre, pose.map, box_, pose.rigid};
}

double PlacedBlock::support(const Vec3& u) const {
  const Vec3& centre = pose_->centre;
  if (index_ == nullptr) {
    double far = -std::numeric_limits<double>::infinity();
    for (const Vec3& x : *world_) far = std::max(far, u.dot(x - centre));
    return far;
  }
  // u·(c + F·r − c) = (Fᵀu)·r. A convex block's farthest vertex by that body-frame value
  // (VertexClimb) is within round-off of the farthest by world value: twice a world
  // vertex's round-off (per coordinate) on top makes it an upper bound.
  if (!index_->climb.empty()) {
    std::int32_t from = -1;
    Vec3 lever;
    return climbed_support(u, from, lever);
  }
  const Vec3 m = pose_->map.transpose() * u;
  // Else bounded over a body box by its centre and half-sizes; the world vertex's
  // round-off (per coordinate) on top.
  const Vec3 abs_m = m.cwiseAbs();
  const double slack = round_off_ * u.cwiseAbs().sum();
  return index_->vertices.maximum(
      [&](const geometry::Aabb& b) { return m.dot(b.center()) + abs_m.dot(0.5 * b.extent()) + slack; },
      [&](std::int32_t i) { return u.dot(world_point(*pose_, model_->vertices[static_cast<std::size_t>(i)]) - centre); });
}

double PlacedBlock::climbed_support(const Vec3& u, std::int32_t& from, Vec3& lever) const {
  from = index_->climb.farthest(model_->vertices, pose_->map.transpose() * u, from);
  lever = world_point(*pose_, model_->vertices[static_cast<std::size_t>(from)]) - pose_->centre;
  return u.dot(lever) + 2.0 * round_off_ * u.cwiseAbs().sum();
}

double PlacedBlock::support_bound(const Vec3& u) const {
  if (index_ == nullptr) return support(u);
  const Vec3 m = pose_->map.transpose() * u;
  const geometry::Aabb& b = index_->body_box;
  return m.dot(b.center()) + m.cwiseAbs().dot(0.5 * b.extent()) + 2.0 * round_off_ * u.cwiseAbs().sum() +
         1e-12 * model_->radius;
}

geometry::Aabb PlacedBlock::body_box(const geometry::Aabb& world) const {
  const Vec3 c = pose_->inverse_map * (world.center() - pose_->centre);
  const Vec3 h = abs_inverse_ * (0.5 * world.extent());
  // The round-off of the world points and of F⁻¹ (a few ulps of |F⁻¹|·|x − centre|).
  const double slack = abs_inverse_.rowwise().sum().maxCoeff() * (round_off_ + kRound * (magnitude(world) + h.maxCoeff()));
  return geometry::Aabb{c - h - Vec3::Constant(slack), c + h + Vec3::Constant(slack)};
}

geometry::Aabb PlacedBlock::world_box(const geometry::Aabb& body) const {
  const Vec3 c = world_point(*pose_, body.center());
  const Vec3 h = pose_->map.cwiseAbs() * (0.5 * body.extent());
  // The round-off of centre + F·r (a few ulps of |centre| + |F|·|r|) on top.
  const double slack = round_off_ + kRound * (c.cwiseAbs().maxCoeff() + h.maxCoeff());
  return geometry::Aabb{c - h - Vec3::Constant(slack), c + h + Vec3::Constant(slack)};
}

}  // namespace talus::dda::detail
