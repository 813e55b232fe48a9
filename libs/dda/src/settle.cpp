// SPDX-License-Identifier: MIT
// The settling of contacts closed through a step (contact_law.hpp, settle_contacts).
#include <algorithm>
#include <cmath>
#include <limits>

#include "contact_law.hpp"

namespace talus::dda::detail {

// Contacts that stay closed through a step have no normal relative velocity in the
// physics: a penalty spring at Ω = √(k/m)·Δt ≫ 1 keeps a barely damped vibration instead,
// which rocks a resting block and turns its friction forces from side to side until it
// creeps down a slope it should stick to. Outside impacts the approaching normal velocity
// of such contacts is therefore removed by non-negative impulses at the contact points
// (projected Gauss–Seidel on the block's mass metric): each impulse only removes kinetic
// energy, and a contact that separates is left to separate. A contact that ends the step
// locked (sticking) has no tangential relative velocity either, yet Shi's velocity update
// v₁ = 2d/Δt − v₀ keeps a velocity that flips sign each step while the displacement
// stays zero (a yaw of ±4e-4 rad/s on a resting cube): its tangential velocity is removed
// too, by impulses each within μ·F_n·Δt/√2 per tangent (inside the Coulomb cone), so a
// sticking contact never holds more than friction could.
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
  // A sweep that leaves the velocity as it found it (to 1e-9 of it in the mass metric,
  // or 1e-12 m/s) ends the iteration too: the impulses of redundant rows, such as the
  // four corners of a face on the ground, can keep trading among themselves while the
  // velocity they leave, which is all this settles, no longer changes.
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
