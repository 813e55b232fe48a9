// SPDX-License-Identifier: MIT
// The settling of contacts closed through a step (contact_law.hpp, settle_contacts).
#include <algorithm>
#include <cmath>
#include <limits>

#include "contact_law.hpp"

namespace talus::dda::detail {

// Contacts closed through a step have no approaching normal velocity (nor, locked,
// tangential within the Coulomb cone): a stiff penalty spring's barely damped vibration
// would make a resting block creep.
template <int N>
void settle_contacts(const Model& model, State& s, const std::vector<Persistent>& persistent) {
  if (persistent.empty()) return;
  const MatN<N> m = current_mass<N>(model, pose_of(model, s));
  const SymmetricSolver<N> llt(m);
  thread_local std::vector<VecN<N>> g, minv_g;
  thread_local std::vector<double> weight, root_weight, impulse, lower, upper, disc;
  g.clear();
  lower.clear();
  upper.clear();
  disc.clear();
  auto add_row = [&](const Vec3& point, const Vec3& direction, double lo, double hi) {
    g.push_back(dof_matrix<N>(point - s.position).transpose() * direction);
    lower.push_back(lo);
    upper.push_back(hi);
    disc.push_back(0.0);
  };
  // Rolling resistance: couples about the two rolling axes, their resultant within a disc
  // of radius μ_r·r·F_n·Δt (a pair of rows), and about the normal within as much.
  const Vec3 omega = s.velocity.template segment<3>(3);
  auto add_turn = [&](const Vec3& axis, double bound, bool pair) {
    VecN<N> row = VecN<N>::Zero();
    row.template segment<3>(3) = axis;
    g.push_back(row);
    lower.push_back(-bound);
    upper.push_back(bound);
    disc.push_back(pair ? bound : 0.0);
  };
  for (const Persistent& c : persistent) {
    add_row(c.point, c.normal, 0.0, std::numeric_limits<double>::infinity());
    const Vec3 t1 = c.normal.unitOrthogonal();
    const Vec3 t2 = c.normal.cross(t1);
    if (c.friction_impulse > 0.0) {
      const double bound = c.friction_impulse / std::sqrt(2.0);
      add_row(c.point, t1, -bound, bound);
      add_row(c.point, t2, -bound, bound);
    }
    if (c.rolling_impulse > 0.0) {
      // The first rolling axis along the rolling (its impulse then the whole disc's radius).
      const Vec3 rolling = omega - c.normal * c.normal.dot(omega);
      const Vec3 r1 = rolling.norm() > 0.0 ? Vec3(rolling.normalized()) : t1;
      add_turn(r1, c.rolling_impulse, true);
      add_turn(c.normal.cross(r1), c.rolling_impulse, false);
      add_turn(c.normal, c.rolling_impulse, false);
    }
  }
  const std::size_t n = g.size();
  minv_g.resize(n);
  weight.assign(n, 0.0);
  root_weight.assign(n, 0.0);
  impulse.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    minv_g[i] = llt.solve(g[i]);
    weight[i] = g[i].dot(minv_g[i]);
    if (weight[i] > 0.0) root_weight[i] = std::sqrt(weight[i]);
  }
  VecN<N> v = s.velocity.template head<N>();
  // A sweep that leaves the velocity as it found it ends the iteration too: redundant rows
  // (a face's four corners) can trade impulses while the velocity, all this settles, no
  // longer changes.
  const double still = 1e-18 * v.dot(m * v) + 1e-24 * model.mass;
  for (int sweep = 0; sweep < 16; ++sweep) {
    const VecN<N> v_start = v;
    double largest = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (disc[i] > 0.0) {
        // A pair of rolling rows: the increment that stops both, shortened to keep the
        // pair's impulse in its disc (a step along it never adds kinetic energy).
        const std::size_t k = i, j = ++i;
        const double wkj = g[k].dot(minv_g[j]);
        const double det = weight[k] * weight[j] - wkj * wkj;
        if (!(det > 1e-14 * weight[k] * weight[j])) continue;
        const double rk = -g[k].dot(v), rj = -g[j].dot(v);
        Eigen::Vector2d step((weight[j] * rk - wkj * rj) / det, (weight[k] * rj - wkj * rk) / det);
        const Eigen::Vector2d from(impulse[k], impulse[j]);
        const double a2 = step.squaredNorm();
        if (!(a2 > 0.0)) continue;
        if ((from + step).norm() > disc[k]) {
          // The largest a ≤ 1 with |from + a·step| ≤ radius (from lies inside).
          const double b = from.dot(step), c = from.squaredNorm() - disc[k] * disc[k];
          step *= std::clamp((-b + std::sqrt(std::max(0.0, b * b - a2 * c))) / a2, 0.0, 1.0);
        }
        v += step[0] * minv_g[k] + step[1] * minv_g[j];
        impulse[k] += step[0];
        impulse[j] += step[1];
        const double moved = step[0] * step[0] * weight[k] + step[1] * step[1] * weight[j] + 2.0 * step[0] * step[1] * wkj;
        largest = std::max(largest, std::sqrt(std::max(0.0, moved)));
        continue;
      }
      if (!(weight[i] > 0.0)) continue;
      const double next = std::clamp(impulse[i] - g[i].dot(v) / weight[i], lower[i], upper[i]);
      const double change = next - impulse[i];
      v += change * minv_g[i];
      impulse[i] = next;
      largest = std::max(largest, std::abs(change) * root_weight[i]);
    }
    if (largest <= 1e-12 * (1.0 + v.norm())) break;
    const VecN<N> change = v - v_start;
    if (change.dot(m * change) <= still) break;
  }
  s.velocity.template head<N>() = v;
}

template void settle_contacts<6>(const Model&, State&, const std::vector<Persistent>&);
template void settle_contacts<12>(const Model&, State&, const std::vector<Persistent>&);

}  // namespace talus::dda::detail
