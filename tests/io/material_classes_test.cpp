// The built-in ground-material classes (libs/terrain/src/material_classes.cpp,
// docs/materials.md) as users set them: `class` in a material's settings, read from YAML.
#include "talus/terrain/material_classes.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "talus/core/error.hpp"
#include "talus/io/settings_yaml.hpp"

namespace talus::terrain {
namespace {

Material read_material(const std::string& yaml) {
  Material m;
  io::read_settings(yaml, "materials.yaml", {}, [&m](core::SettingsVisitor& v) { m.visit(v); });
  return m;
}

void expect_parameters_of(const Material& m, const MaterialClass& c) {
  EXPECT_EQ(m.restitution_mean, c.restitution_mean) << c.name;
  EXPECT_EQ(m.restitution_sd, c.restitution_sd) << c.name;
  EXPECT_EQ(m.restitution_scale, c.restitution_scale) << c.name;
  EXPECT_EQ(m.friction_angle_mean_deg, c.friction_angle_mean_deg) << c.name;
  EXPECT_EQ(m.friction_coefficient_sd, c.friction_coefficient_sd) << c.name;
  EXPECT_EQ(m.lateral_tilt_sd_deg, c.lateral_tilt_sd_deg) << c.name;
}

// Every class of the table is a value the settings accept (the choice list of `class`
// and the table are written separately) and sets all six parameters.
TEST(MaterialClasses, EveryClassReadsWithItsParameters) {
  ASSERT_GE(material_classes().size(), 7u);
  for (const MaterialClass& c : material_classes()) {
    const Material m = read_material("name: ground\nclass: " + std::string(c.name) + "\n");
    EXPECT_EQ(m.class_name, c.name);
    expect_parameters_of(m, c);
  }
  const Material plain = read_material("name: ground\n");
  EXPECT_EQ(plain.class_name, "none");
  EXPECT_EQ(plain.restitution_mean, Material{}.restitution_mean);
}

// Parameters given beside the class win, wherever they stand in the file.
TEST(MaterialClasses, ParametersGivenBesideTheClassOverrideIt) {
  const MaterialClass& scree = *find_material_class("loose_scree");
  for (const std::string yaml : {"class: loose_scree\nfriction_angle_mean_deg: 20\nlateral_tilt_sd_deg: 4\n",
                                 "friction_angle_mean_deg: 20\nlateral_tilt_sd_deg: 4\nclass: loose_scree\n"}) {
    const Material m = read_material(yaml);
    EXPECT_EQ(m.friction_angle_mean_deg, 20.0);
    EXPECT_EQ(m.lateral_tilt_sd_deg, 4.0);
    EXPECT_EQ(m.restitution_mean, scree.restitution_mean);
    EXPECT_EQ(m.restitution_scale, scree.restitution_scale);
  }
}

TEST(MaterialClasses, UnknownClassIsAOneLineErrorNamingTheClasses) {
  try {
    read_material("name: ground\nclass: granite\n");
    FAIL() << "an unknown class was accepted";
  } catch (const core::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("materials.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("granite"), std::string::npos) << message;
    EXPECT_NE(message.find("bedrock"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  Material m;
  EXPECT_THROW(apply_material_class(m, "granite", "scene.yaml"), core::InputError);
}

// The classes are valid materials, ordered as their published normal restitutions, and
// R_v exceeds R_n (part of a real impact's energy goes into spin, docs/materials.md).
TEST(MaterialClasses, ParametersAreValidAndFollowThePublishedOrder) {
  const Material::Ranges r = Material::ranges();
  for (const MaterialClass& c : material_classes()) {
    EXPECT_TRUE(r.restitution_mean.contains(c.restitution_mean)) << c.name;
    EXPECT_TRUE(r.restitution_sd.contains(c.restitution_sd)) << c.name;
    EXPECT_TRUE(r.restitution_scale.contains(c.restitution_scale)) << c.name;
    EXPECT_TRUE(r.friction_angle_mean_deg.contains(c.friction_angle_mean_deg)) << c.name;
    EXPECT_TRUE(r.friction_coefficient_sd.contains(c.friction_coefficient_sd)) << c.name;
    EXPECT_TRUE(r.lateral_tilt_sd_deg.contains(c.lateral_tilt_sd_deg)) << c.name;
    EXPECT_GT(c.restitution_mean, c.normal_restitution) << c.name;
    EXPECT_FALSE(c.ground.empty());
    EXPECT_NE(c.source.find("R_n"), std::string_view::npos) << c.name;
  }
  for (const MaterialClass& a : material_classes())
    for (const MaterialClass& b : material_classes())
      if (a.normal_restitution < b.normal_restitution) {
        EXPECT_LE(a.restitution_mean, b.restitution_mean) << a.name << " " << b.name;
      }
}

// What --print-config writes (the class and the six resolved parameters) reads back to
// the same material.
TEST(MaterialClasses, PrintedMaterialReadsBackIdentically) {
  Material m = read_material("name: road\nclass: asphalt\nrestitution_sd: 0.01\n");
  const std::string text = io::write_settings([&m](core::SettingsVisitor& v) { m.visit(v); }, true);
  Material back = read_material(text);
  EXPECT_EQ(back.class_name, "asphalt");
  EXPECT_EQ(back.restitution_sd, 0.01);
  EXPECT_EQ(back.restitution_mean, m.restitution_mean);
  EXPECT_EQ(io::write_settings([&back](core::SettingsVisitor& v) { back.visit(v); }, false),
            io::write_settings([&m](core::SettingsVisitor& v) { m.visit(v); }, false));
}

}  // namespace
}  // namespace talus::terrain
