#include "talus/terrain/material_classes.hpp"

#include <algorithm>
#include <array>
#include <cstdio>

#include "talus/core/error.hpp"

namespace talus::terrain {

namespace {

// Each class reproduces the mean normal restitution R_n of a Rockyfor3D soil type
// (Dorren 2016, "Rockyfor3D (v5.2) revealed", Table 1): R_v is the mean restitution whose
// median normal restitution e_n, for 1 m³ tetrahedra, cubes, octahedra and dodecahedra of
// random orientation striking the class's ground normally at 10 m/s, is R_n, measured
// through terrain-gen, block-gen and dda-run by
//   bench/materials/impacts.py --fit NAME:RN:PHI --realizations 256
// (docs/materials.md). Like Rockyfor3D's R_n, the classes do not depend on the impact
// speed (K = 1000 m/s: SF > 0.999 below 30 m/s). The sd of R_v spreads it as Rockyfor3D's
// R_n range read as a uniform spread: sd = R_v · (half range / R_n) / √3. Friction angles:
// rock on rock and on asphalt 30° (basic friction angles of 25–35°, Barton & Choubey
// 1977); scree 35° (its angle of repose); soils 30°. Ground under grass or shrubs has no
// class of its own: like Rockyfor3D, take the class of the soil beneath (docs/materials.md).
constexpr std::array kClasses{
    MaterialClass{"bedrock", "hard bedrock, outcrops, clean rock faces", "Rockyfor3D soil type 6 (R_n 0.53, 0.48-0.58)",
                  0.53, 0.82, 0.045, 1000.0, 30.0, 0.05, 0.0},
    MaterialClass{"bedrock_thin_cover", "bedrock with a thin weathered layer or soil cover",
                  "Rockyfor3D soil type 5 (R_n 0.43, 0.39-0.47)", 0.43, 0.66, 0.035, 1000.0, 30.0, 0.05, 0.0},
    MaterialClass{"compact_scree", "talus of fragments larger than ~10 cm, compact soil with large rock fragments",
                  "Rockyfor3D soil type 4 (R_n 0.38, 0.34-0.42)", 0.38, 0.59, 0.036, 1000.0, 35.0, 0.05, 0.0},
    MaterialClass{"loose_scree", "scree of fragments smaller than ~10 cm, medium compact soil with small rock "
                  "fragments, forest road", "Rockyfor3D soil type 3 (R_n 0.33, 0.30-0.36)", 0.33, 0.51, 0.027, 1000.0,
                  35.0, 0.05, 0.0},
    MaterialClass{"soil", "fine soil less than ~1 m deep, sand and gravel mix of valley floors",
                  "Rockyfor3D soil type 2 (R_n 0.28, 0.25-0.31)", 0.28, 0.44, 0.027, 1000.0, 30.0, 0.05, 0.0},
    MaterialClass{"deep_soil", "fine soil deeper than ~1 m", "Rockyfor3D soil type 1 (R_n 0.23, 0.21-0.25)", 0.23,
                  0.36, 0.018, 1000.0, 30.0, 0.05, 0.0},
    MaterialClass{"asphalt", "asphalt road", "Rockyfor3D soil type 7 (R_n 0.35, 0.32-0.39)", 0.35, 0.54, 0.031,
                  1000.0, 30.0, 0.05, 0.0},
};

}  // namespace

std::span<const MaterialClass> material_classes() { return kClasses; }

const MaterialClass* find_material_class(std::string_view name) {
  const auto it = std::find_if(kClasses.begin(), kClasses.end(), [&](const MaterialClass& c) { return c.name == name; });
  return it == kClasses.end() ? nullptr : &*it;
}

void apply_material_class(Material& m, std::string_view name, const std::string& source) {
  const MaterialClass* c = find_material_class(name);
  if (c == nullptr) {
    std::string known;
    for (const MaterialClass& k : kClasses) known += (known.empty() ? "" : ", ") + std::string(k.name);
    throw core::InputError(source, "material '" + m.name + "': unknown class '" + std::string(name) +
                                       "' (known: " + known + ")");
  }
  m.restitution_mean = c->restitution_mean;
  m.restitution_sd = c->restitution_sd;
  m.restitution_scale = c->restitution_scale;
  m.friction_angle_mean_deg = c->friction_angle_mean_deg;
  m.friction_coefficient_sd = c->friction_coefficient_sd;
  m.lateral_tilt_sd_deg = c->lateral_tilt_sd_deg;
}

void visit_material_class(core::SettingsVisitor& v, std::string& class_name, Material* target) {
  const std::string before = class_name;
  // The list must name every entry of kClasses (a test checks it).
  v.choice("class", class_name,
           {"none", "bedrock", "bedrock_thin_cover", "compact_scree", "loose_scree", "soil", "deep_soil",
            "asphalt"},
           "starting material class (docs/materials.md, terrain-gen --list-material-classes): sets the six "
           "parameters below, which override it where given; none: the parameters alone");
  if (target != nullptr && class_name != before && class_name != "none")
    apply_material_class(*target, class_name, "settings");
}

std::string material_classes_table() {
  std::string out =
      "class               R_v mean  R_v sd  K (m/s)  phi (deg)  tan(phi) sd  tilt sd (deg)  R_n\n";
  char line[256];
  for (const MaterialClass& c : kClasses) {
    std::snprintf(line, sizeof line, "%-19s %8.3f  %6.3f  %7.0f  %9.1f  %11.3f  %13.1f  %.2f\n",
                  std::string(c.name).c_str(), c.restitution_mean, c.restitution_sd, c.restitution_scale,
                  c.friction_angle_mean_deg, c.friction_coefficient_sd, c.lateral_tilt_sd_deg, c.normal_restitution);
    out += line;
    out += "    " + std::string(c.ground) + "; " + std::string(c.source) + "\n";
  }
  out += "# Set with materials[].class in terrain-gen settings (or a scene's material override); parameters given\n"
         "# beside the class override it. Sources and how to calibrate: docs/materials.md.\n";
  return out;
}

}  // namespace talus::terrain
