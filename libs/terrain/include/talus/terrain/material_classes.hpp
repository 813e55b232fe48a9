// SPDX-License-Identifier: MIT
#pragma once
#include <span>
#include <string>
#include <string_view>

#include "talus/core/settings.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

/// A documented starting set of ground-material parameters (docs/materials.md): the
/// material law's six parameters for one kind of ground, with where they come from.
struct MaterialClass {
  std::string_view name;         ///< settings value of `class` (e.g. "loose_scree")
  std::string_view ground;       ///< the ground it stands for, in words
  std::string_view source;       ///< the published class it reproduces
  double normal_restitution;     ///< the published mean normal restitution R_n it reproduces (-)
  double restitution_mean;       ///< R_v mean (-)
  double restitution_sd;         ///< R_v sd (-)
  double restitution_scale;      ///< K (m/s)
  double friction_angle_mean_deg;
  double friction_coefficient_sd;
  double lateral_tilt_sd_deg;
};

/// The built-in classes, in the order docs/materials.md lists them.
std::span<const MaterialClass> material_classes();

/// The class named `name`, or nullptr.
const MaterialClass* find_material_class(std::string_view name);

/// Sets the six parameters of `m` from class `name`; throws core::InputError(source, …)
/// naming the known classes when there is no such class.
void apply_material_class(Material& m, std::string_view name, const std::string& source);

/// Visits the `class` setting (one of the classes, or "none"). When the visitor reads a
/// new value and `target` is given, `target` takes that class's parameters at once, so
/// parameters read after it override the class.
void visit_material_class(core::SettingsVisitor& v, std::string& class_name, Material* target);

/// The table printed by `terrain-gen --list-material-classes`.
std::string material_classes_table();

}  // namespace talus::terrain
