// The settings structs of the terrain library declare every field once, with its unit;
// a visitor that records the declarations and writes values stands in for the YAML
// reader (tested in tests/io).
#include <gtest/gtest.h>

#include <map>

#include "talus/core/settings.hpp"
#include "talus/terrain/materials.hpp"
#include "talus/terrain/synthetic.hpp"

namespace talus::terrain {
namespace {

class Recorder : public core::SettingsVisitor {
 public:
  std::map<std::string, std::string> units;  // key → unit ("" for unitless kinds)
  std::map<std::string, std::vector<std::string>> choices;
  std::map<std::string, double> set_numbers;  // values to write into the struct
  std::map<std::string, std::string> set_strings;

  void field(std::string_view key, double& value, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
    if (auto it = set_numbers.find(std::string(key)); it != set_numbers.end()) value = it->second;
  }
  void field(std::string_view key, std::optional<double>&, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
  }
  void field(std::string_view key, std::int64_t&, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
  }
  void field(std::string_view key, std::uint64_t&, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
  }
  void field(std::string_view key, bool&, std::string_view) override { units[std::string(key)] = ""; }
  void field(std::string_view key, std::string& value, std::string_view) override {
    units[std::string(key)] = "";
    if (auto it = set_strings.find(std::string(key)); it != set_strings.end()) value = it->second;
  }
  void field(std::string_view key, std::array<double, 3>&, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
  }
  void field(std::string_view key, std::vector<double>&, std::string_view unit, std::string_view) override {
    units[std::string(key)] = unit;
  }
  void field(std::string_view key, std::vector<std::string>&, std::string_view) override {
    units[std::string(key)] = "";
  }
  void field(std::string_view key, std::vector<std::array<double, 2>>& value, std::string_view unit,
             std::string_view) override {
    units[std::string(key)] = unit;
    if (key == "profile" || key == "polygon") value = {{0, 3}, {2, 1}, {4, 0}};
  }
  void choice(std::string_view key, std::string& value, std::initializer_list<std::string_view> allowed,
              std::string_view) override {
    units[std::string(key)] = "";
    for (auto a : allowed) choices[std::string(key)].emplace_back(a);
    if (auto it = set_strings.find(std::string(key)); it != set_strings.end()) value = it->second;
  }
  void section(std::string_view, std::string_view, const std::function<void(SettingsVisitor&)>& body) override {
    body(*this);
  }
  void list(std::string_view, std::string_view, const ListAccess&) override {}
};

TEST(SyntheticSlopeSettings, DeclaresEveryFieldWithItsUnit) {
  SyntheticSlope s;
  Recorder r;
  r.set_strings["kind"] = "profile";
  r.set_numbers["cell_size"] = 1.0;
  r.set_numbers["width"] = 2.0;
  s.visit(r);
  EXPECT_EQ(r.units, (std::map<std::string, std::string>{{"kind", ""},
                                                         {"cell_size", "m"},
                                                         {"width", "m"},
                                                         {"length", "m"},
                                                         {"slope_angle_deg", "deg"},
                                                         {"profile", "m"}}));
  EXPECT_EQ(r.choices["kind"], (std::vector<std::string>{"bench", "plane", "profile"}));
  // The values written through the visitor drive make_synthetic.
  const DemGrid d = make_synthetic(s, "slope.yaml");
  EXPECT_EQ(d.spec.nx, 5);
  EXPECT_EQ(d.spec.ny, 3);
  EXPECT_EQ(d.z[d.spec.index(2, 1)], 1.0);
}

TEST(MaterialSettings, ZoneAndMaterialDeclareTheirFields) {
  MaterialZone z;
  Recorder r;
  r.set_strings["material"] = "rock";
  z.visit(r);
  EXPECT_EQ(r.units, (std::map<std::string, std::string>{{"material", ""}, {"polygon", "m"}}));
  EXPECT_EQ(z.material, "rock");
  EXPECT_EQ(z.polygon.size(), 3u);

  Material m;
  Recorder rm;
  m.visit(rm);
  EXPECT_EQ(rm.units["friction_angle_mean_deg"], "deg");
  EXPECT_EQ(rm.units["restitution_scale"], "m/s");
  EXPECT_EQ(rm.units["ploughing"], "-");
  EXPECT_EQ(rm.units.size(), 9u);  // name, class and the seven properties
  EXPECT_EQ(rm.choices["class"].front(), "none");
}

}  // namespace
}  // namespace talus::terrain
