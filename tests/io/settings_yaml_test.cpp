#include "talus/io/settings_yaml.hpp"

#include <gtest/gtest.h>

#include "talus/core/error.hpp"

namespace talus::io {
namespace {

struct Zone {
  std::string name = "rock";
  std::vector<std::array<double, 2>> polygon;
  void visit(core::SettingsVisitor& v) {
    v.field("name", name, "zone name");
    v.field("polygon", polygon, "m", "outline");
  }
};

struct Example {
  double sigma = 0.1;
  std::optional<double> index;
  std::int64_t count = 3;
  std::uint64_t seed = 1;
  bool flag = false;
  std::string mode = "alternating";
  std::array<double, 3> origin{0, 0, 0};
  std::vector<Zone> zones;
  double inner = 2.0;
  void visit(core::SettingsVisitor& v) {
    v.field("sigma", sigma, "m", "roughness");
    v.field("index", index, "-", "roughness index");
    v.field("count", count, "-", "a count");
    v.field("seed", seed, "-", "seed");
    v.field("flag", flag, "a flag");
    v.choice("mode", mode, {"fixed", "alternating", "random"}, "diagonal");
    v.field("origin", origin, "m", "origin");
    v.list_of("zones", "material zones", zones);
    v.section("nested", "a section", [this](core::SettingsVisitor& s) { s.field("inner", inner, "m", "inner value"); });
  }
};

SettingsBody bind(Example& e) {
  return [&e](core::SettingsVisitor& v) { e.visit(v); };
}

TEST(SettingsYaml, ReadsValuesOverDefaults) {
  Example e;
  read_settings("sigma: 0.4\nindex: 0.25\nmode: random\norigin: [1, 2, 3]\nnested: {inner: 7}\n"
                "zones:\n  - {name: scree, polygon: [[0, 0], [1, 0], [1, 1]]}\n",
                "a.yaml", {}, bind(e));
  EXPECT_EQ(e.sigma, 0.4);
  EXPECT_EQ(*e.index, 0.25);
  EXPECT_EQ(e.count, 3);
  EXPECT_EQ(e.mode, "random");
  EXPECT_EQ(e.origin[2], 3.0);
  EXPECT_EQ(e.inner, 7.0);
  ASSERT_EQ(e.zones.size(), 1u);
  EXPECT_EQ(e.zones[0].name, "scree");
  EXPECT_EQ(e.zones[0].polygon.size(), 3u);
}

TEST(SettingsYaml, UnknownKeyNamesKeyFileAndLineWithSuggestion) {
  Example e;
  try {
    read_settings("sigma: 0.4\nnested:\n  innr: 3\n", "slope.yaml", {}, bind(e));
    FAIL() << "no error";
  } catch (const core::InputError& err) {
    EXPECT_STREQ(err.what(), "slope.yaml:3: unknown key 'nested.innr' (did you mean 'nested.inner'?)");
    EXPECT_EQ(err.code(), core::ExitCode::bad_input);
  }
  // A key given at the wrong level: the key of that name (or a close one) elsewhere.
  const auto message = [&](const std::string& yaml, const std::vector<std::string>& overrides) {
    try {
      read_settings(yaml, "slope.yaml", overrides, bind(e));
    } catch (const core::InputError& err) {
      return std::string(err.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("inner: 3\n", {}), "slope.yaml:1: unknown key 'inner' (did you mean 'nested.inner'?)");
  EXPECT_EQ(message("", {"nested.sigma=0.2"}), "--set nested.sigma: unknown key 'nested.sigma' (did you mean 'sigma'?)");
  EXPECT_EQ(message("zzzz: 1\n", {}), "slope.yaml:1: unknown key 'zzzz'");
}

// A key given twice in one mapping, at the top, in a section or in a list item, is an
// error naming the second's line and the first's (an override appended at the end of a
// file was silently dropped).
TEST(SettingsYaml, DuplicateKeysAreErrors) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"sigma: 0.4\ncount: 2\nsigma: 0.5\n", "d.yaml:3: duplicate key 'sigma' (first given at line 1)"},
      {"nested:\n  inner: 1\n  inner: 2\n", "d.yaml:3: duplicate key 'inner' (first given at line 2)"},
      {"zones:\n  - {name: a, name: b}\n", "d.yaml:2: duplicate key 'name' (first given at line 2)"},
  };
  for (const auto& [text, expected] : cases) {
    Example e;
    try {
      read_settings(text, "d.yaml", {}, bind(e));
      ADD_FAILURE() << "no error for " << text;
    } catch (const core::InputError& err) {
      EXPECT_EQ(std::string(err.what()), expected);
      EXPECT_EQ(err.code(), core::ExitCode::bad_input);
    }
  }
  // The same key in different mappings is no duplicate.
  Example e;
  read_settings("sigma: 0.4\nzones:\n  - {name: a}\n  - {name: b}\n", "d.yaml", {}, bind(e));
  EXPECT_EQ(e.zones.size(), 2u);
}

TEST(SettingsYaml, WrongTypesAreErrors) {
  Example e;
  EXPECT_THROW(read_settings("sigma: abc\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("count: 1.5\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("seed: -1\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("mode: diagonal\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("origin: [1, 2]\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("sigma: .nan\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("- 1\n- 2\n", "f", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("sigma: [1\n", "f", {}, bind(e)), core::InputError);
}

TEST(SettingsYaml, OverridesApplyAfterFile) {
  Example e;
  read_settings("sigma: 0.4\n", "f", {"sigma=0.8", "nested.inner=9", "zones=[{name: a}]", "zones[0].name=b"}, bind(e));
  EXPECT_EQ(e.sigma, 0.8);
  EXPECT_EQ(e.inner, 9.0);
  ASSERT_EQ(e.zones.size(), 1u);
  EXPECT_EQ(e.zones[0].name, "b");
  EXPECT_THROW(read_settings("", "f", {"nosuch=1"}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("", "f", {"sigma"}, bind(e)), core::UsageError);
  EXPECT_THROW(read_settings("", "f", {"zones[5].name=x"}, bind(e)), core::UsageError);
}

TEST(SettingsYaml, OverrideReachesAnItemOfTheDefaultList) {
  Example e;
  e.zones.resize(2);
  e.zones[0].name = "a";
  e.zones[1].name = "c";
  read_settings("sigma: 0.4\n", "f", {"zones[1].name=z"}, bind(e));
  ASSERT_EQ(e.zones.size(), 2u);
  EXPECT_EQ(e.zones[0].name, "a");
  EXPECT_EQ(e.zones[1].name, "z");
}

TEST(SettingsYaml, SelfNestingAliasesAndEmptySectionsAreErrors) {
  Example e;
  EXPECT_THROW(read_settings("sigma: &a [*a]\n", "loop.yaml", {}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("", "f", {"nested="}, bind(e)), core::InputError);
  EXPECT_THROW(read_settings("", "f", {"zones="}, bind(e)), core::InputError);
}

// Where each value came from, for checks made after reading (core::SettingsOrigins).
TEST(SettingsYaml, OriginsNameTheLineOrTheSetKeyOfEachValue) {
  Example e;
  core::SettingsOrigins origins("a.yaml");
  read_settings("sigma: 0.4\nnested:\n  inner: 7\nzones:\n  - name: scree\n    polygon: [[0, 0], [1, 0], [1, 1]]\n"
                "  - name: mud\n",
                "a.yaml", {"zones[1].polygon=[[0, 0]]", "count=4"}, bind(e), &origins);
  EXPECT_EQ(origins.of("sigma"), "a.yaml:1");
  EXPECT_EQ(origins.of("nested.inner"), "a.yaml:3");
  EXPECT_EQ(origins.of("zones[0].polygon"), "a.yaml:6");
  EXPECT_EQ(origins.of("zones[1].polygon"), "--set zones[1].polygon");
  EXPECT_EQ(origins.of("count"), "--set count");
  // A key an item does not give is its default, in the item given at that line; a key
  // nobody gave is named by the file alone.
  EXPECT_EQ(origins.of("zones[1].name"), "a.yaml:7");
  EXPECT_EQ(origins.of("mode"), "a.yaml");
  // A message about two values names the one an override gave.
  EXPECT_EQ(origins.of({"zones[0].polygon", "count"}), "--set count");
  EXPECT_EQ(origins.of({"sigma", "nested.inner"}), "a.yaml:1");
  EXPECT_EQ(origins.within("nested").of("inner"), "a.yaml:3");
  EXPECT_EQ(origins.within("zones").of("[1].polygon"), "--set zones[1].polygon");

  // A section or list given whole by --set names that --set for every value in it.
  core::SettingsOrigins whole("settings");
  read_settings("", "--set", {"zones=[{name: a, polygon: [[0, 0]]}]"}, bind(e), &whole);
  EXPECT_EQ(whole.of("zones[0].polygon"), "--set zones");
  EXPECT_EQ(whole.of("sigma"), "settings");

  // Overrides from another file's list are named by it.
  core::SettingsOrigins listed("scene.yaml");
  read_settings("sigma: 0.4\n", "scene.yaml", {"sigma=0.5"}, bind(e), &listed, {"cal.yaml:7: set"});
  EXPECT_EQ(listed.of("sigma"), "cal.yaml:7: set sigma");
  try {
    read_settings("", "scene.yaml", {"mode=diagonal"}, bind(e), nullptr, {"cal.yaml:7: set"});
    ADD_FAILURE() << "a value outside the choice is refused";
  } catch (const core::InputError& err) {
    EXPECT_EQ(err.source(), "cal.yaml:7: set mode");
  }
}

TEST(SettingsYaml, PrintedSettingsReadBackIdentically) {
  Example e;
  e.sigma = 0.1 + 0.2;  // not exactly representable in short decimal
  e.index = 0.5;
  e.zones = {Zone{"a", {{0, 0}, {1, 2}}}};
  const std::string text = write_settings(bind(e), true);
  EXPECT_NE(text.find("[m] roughness"), std::string::npos);
  Example back;
  read_settings(text, "printed", {}, bind(back));
  EXPECT_EQ(back.sigma, e.sigma);
  EXPECT_EQ(*back.index, 0.5);
  EXPECT_EQ(back.zones[0].polygon[1][1], 2.0);
  EXPECT_EQ(write_settings(bind(back), false), write_settings(bind(e), false));
}

}  // namespace
}  // namespace talus::io
