#include "talus/io/observed.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "talus/core/error.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

ObservedStops read_text(const std::string& name, const std::string& text) {
  const std::string path = talus::testing::temp_path("observed_test", name);
  std::ofstream(path) << text;
  ObservedStops out = read_observed_stops(path, "", "", "observed.file");
  std::filesystem::remove(path);
  return out;
}

// Each form of CSV a field team writes gives the same points: one separator a file, so a
// name with a space is one field, and a semicolon file's decimal commas are decimals.
TEST(ObservedStops, CsvSeparatorsNamesWithSpacesAndDecimalCommas) {
  const std::vector<std::array<double, 2>> expected = {{2601068.4, 1180031.2}, {2601050.25, 1180020.5}};
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"plain.csv", "x,y\n2601068.4,1180031.2\n2601050.25,1180020.5\n"},
           {"named.csv", "# surveyed 2026-05-02\nname,x,y\nstone 1,2601068.4,1180031.2\nstone 2,2601050.25,1180020.5\n"},
           {"euro.csv", "id;easting;northing\n1;2601068,4;1180031,2\n2;2601050,25;1180020,5\n"},
           {"tabs.txt", "id\tE\tx\ty\n1\ta b\t2601068.4\t1180031.2\n2\tc\t2601050.25\t1180020.5\n"},
           {"spaces.xy", "2601068.4   1180031.2\r\n 2601050.25 1180020.5\r\n"},
       }) {
    const ObservedStops o = read_text(name, text);
    EXPECT_EQ(o.points, expected) << name;
  }
  // A line that misses a value is named.
  EXPECT_THROW(read_text("short.csv", "name,x,y\nstone 1,2601068.4\n"), core::InputError);
}

// Each stop knows its line, comments and header counted, so a message can name it.
TEST(ObservedStops, EachStopKnowsItsLine) {
  const ObservedStops points = read_text("rows.csv", "# surveyed\nx,y\n1,2\n\n3,4\n");
  EXPECT_EQ(points.rows, (std::vector<std::string>{"line 3", "line 5"}));
  const ObservedStops runouts = read_text("runouts.csv", "runout,lateral\n10,1\n12,-1\n");
  EXPECT_EQ(runouts.rows, (std::vector<std::string>{"line 2", "line 3"}));
}

}  // namespace
}  // namespace talus::io
