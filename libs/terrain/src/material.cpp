#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

void Material::visit(core::SettingsVisitor& v) {
  v.field("name", name, "material name");
  v.field("restitution_mean", restitution_mean, "-", "mean of the scaled restitution R_v");
  v.field("restitution_sd", restitution_sd, "-", "standard deviation of R_v");
  v.field("restitution_scale", restitution_scale, "m/s", "K in SF = 1/(1 + (V_in/K)^2)");
  v.field("friction_angle_mean_deg", friction_angle_mean_deg, "deg", "mean friction angle");
  v.field("friction_coefficient_sd", friction_coefficient_sd, "-",
          "standard deviation of the friction coefficient tan(phi)");
  v.field("lateral_tilt_sd_deg", lateral_tilt_sd_deg, "deg",
          "standard deviation of the lateral ground tilt drawn at each impact");
}

}  // namespace talus::terrain
