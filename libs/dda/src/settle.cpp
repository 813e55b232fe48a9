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
  thread_local std::vector<double> weight, root_weight, impulse, lower, upper;
  g.clear();
  lower.clear();
  upper.clear();
  auto add_row = [&](const Vec3& point, const Vec3& direction, double lo, double hi) {
    g.push_back(dof_matrix<N>(point - s.position).transpose() * direction);
    lower.push_back(lo);
    upper.push_back(hi);
  };
  for (const Persistent& c : persistent) {
    add_row(c.point, c.normal, 0.0, std::numeric_limits<double>::infinity());
    if (!(c.friction_impulse > 0.0)) continue;
    const Vec3 t1 = c.normal.unitOrthogonal();
    const Vec3 t2 = c.normal.cross(t1);
    const double bound = c.friction_impulse / std::sqrt(2.0);
    add_row(c.point, t1, -bound, bound);
    add_row(c.point, t2, -bound, bound);
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
