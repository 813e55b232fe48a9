#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/core/settings.hpp"

namespace talus::core {
namespace {

// A settings struct with a bounded number, a nested section and a list of items.
struct Item {
  double mass = 1.0;
  void visit(SettingsVisitor& v) { v.bounded("mass", mass, "kg", "item mass", Range{0.0, 10.0, true, false}); }
};

struct Example {
  double step = 1e-3;
  std::int64_t count = 3;
  double free = -5.0;  // not bounded: never checked
  std::string mode = "fast";
  Item inner;
  std::vector<Item> items{Item{}, Item{}};
  void visit(SettingsVisitor& v) {
    v.bounded("step", step, "s", "time step", Range::positive(0.05));
    v.bounded("count", count, "-", "how many", Range::closed(1.0, 100.0));
    v.field("free", free, "m", "any number");
    v.choice("mode", mode, {"fast", "exact"}, "how");
    v.section("inner", "nested", [this](SettingsVisitor& s) { inner.visit(s); });
    v.list_of("items", "listed", items);
  }
};

std::string range_error(Example e) {
  try {
    check_ranges([&](SettingsVisitor& v) { e.visit(v); }, "example settings");
  } catch (const InputError& err) {
    return err.what();
  }
  return "";
}

TEST(CoreSettings, CheckRangesNamesTheFieldItsValueAndItsDeclaredRange) {
  EXPECT_EQ(range_error(Example{}), "");
  Example e;
  e.step = 0.1;
  EXPECT_EQ(range_error(e), "example settings: step = 0.1: must be in (0, 0.05] s");
  e = Example{};
  e.count = 0;
  EXPECT_EQ(range_error(e), "example settings: count = 0: must be in [1, 100]");
  // Sections and list items are named by their path.
  e = Example{};
  e.inner.mass = 0.0;
  EXPECT_EQ(range_error(e), "example settings: inner.mass = 0: must be in (0, 10] kg");
  e = Example{};
  e.items[1].mass = 11.0;
  EXPECT_EQ(range_error(e), "example settings: items[1].mass = 11: must be in (0, 10] kg");
  // Not finite is out of any range, an open upper end included.
  e = Example{};
  e.step = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(range_error(e).find("step = "), std::string::npos);
  Item open;
  open.mass = std::numeric_limits<double>::infinity();
  EXPECT_THROW(check_ranges(
                   [&](SettingsVisitor& v) {
                     v.bounded("mass", open.mass, "kg", "mass", Range{0.0, std::numeric_limits<double>::infinity()});
                   },
                   "example settings"),
               InputError);
  // A choice outside its values.
  e = Example{};
  e.mode = "slow";
  EXPECT_EQ(range_error(e), "example settings: mode = 'slow': must be one of fast, exact");
  // A field without a range is not checked.
  e = Example{};
  e.free = -1e300;
  EXPECT_EQ(range_error(e), "");
}

}  // namespace
}  // namespace talus::core
