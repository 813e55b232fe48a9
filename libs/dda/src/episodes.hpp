// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>

#include "talus/dda/engine.hpp"

namespace talus::dda::detail {

/// The material of a terrain triangle; throws core::InputError ("terrain") if the
/// triangle names a material `ground` lacks.
const terrain::Material& material_of(const Ground& ground, std::int32_t triangle);
/// tan of the material's mean friction angle (-).
double mean_friction(const terrain::Material& mat);

/// The approach of the fastest contact point that closes: its speed along the contact
/// normal, translation and spin (m/s), and the kinetic energy of that approach on the
/// block's effective mass at the point (J).
struct PointApproach {
  double speed = 0.0;
  double energy = 0.0;
  Vec3 point = Vec3::Zero();  ///< the point, from the centroid at the step start (m)
};

/// Starts a contact episode with the centroid velocity `v_in` (m/s) and rigid kinetic
/// energy `kinetic_in` (J) of the step start; an impact when the closing contact point
/// approaches the ground at impact_min_normal_speed or faster (draws R_v, μ and the lateral
/// tilt).
void start_episode(const Model& model, const Ground& ground, State& s, const Vec3& v_in, double kinetic_in,
                   PointApproach point);
/// The same along a given ground `normal` (unit), the material that of `triangle`: an
/// impact that arrives while other contacts are closed (docs/dda.md, Impact–rebound).
void start_episode_along(const Model& model, const Ground& ground, State& s, const Vec3& v_in, double kinetic_in,
                         const Vec3& normal, std::int32_t triangle, PointApproach point);
/// The last contact to let go in a step that ends an impact: its end gap (m, > 0), unit
/// normal, block point at the step's end (world, m) and the step's length (s). The block
/// flew from that moment at the raw rebound; the law's rebound belongs to that moment.
struct Separation {
  double gap = 0.0;
  Vec3 normal = Vec3::UnitZ();
  Vec3 point = Vec3::Zero();
  double step = 0.0;
};

/// Applies the restitution law to the rebound of the impact in progress; the episode
/// goes on as a rolling/sliding one if contacts stay closed. With a `separation` the law
/// acts on the velocity at the moment of separation and the flight since is redone with
/// the law's rebound.
void finish_impact(const Model& model, State& s, const Separation& separation = {});
/// Ends the episode (applying the law if it is an impact); `separation` as for finish_impact.
void end_episode(const Model& model, State& s, const Separation& separation = {});
/// Adds a step's contact impulse (N·s) and its moment about the centroid (N·s·m) to the
/// impact in progress: where the contact-point law acts.
void add_impulse(State& s, double impulse, const Vec3& moment);
/// True once an impact whose block stays in contact has rebounded (docs/dda.md).
bool rebound_complete(const Model& model, const State& s, double spring_energy);

}  // namespace talus::dda::detail
