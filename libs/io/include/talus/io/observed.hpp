// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <string>
#include <vector>

namespace talus::io {

/// Observed stops of a field campaign or a past event, as a file gives them: stop points
/// (plan x, y in the terrain's input coordinates, m), or runouts from a known origin (m)
/// with, optionally, their lateral offsets (m, positive to the left).
struct ObservedStops {
  std::vector<std::array<double, 2>> points;  ///< when the file gives points
  std::vector<double> runout;                 ///< when the file gives runouts (a `runout` column)
  std::vector<double> lateral;                ///< with runouts, when it has a `lateral` column
  /// Where each stop (point or runout) is in the file, for messages: "line 7" of a CSV,
  /// "feature 3" of a vector file (its OGR feature id), "realization 12" of a run file.
  std::vector<std::string> rows;
  bool has_points() const { return !points.empty(); }
};

/// Reads observed stops from a CSV (`#` comment lines; one separator a file, from its first
/// other line: a semicolon, whose files may write decimal commas, else a comma, else a tab,
/// else runs of spaces; a name with a space in it is one field): a header naming x and y
/// (or easting and northing) picks
/// those columns; a header naming `runout` (and `lateral`) gives runouts; no header: the
/// first two columns are x and y. A `.h5` is a dda-run run file: the stop points of its
/// realizations at rest (a synthetic experiment). Any other extension is a vector file of points (read by
/// OGR; a layer whose CRS differs from `terrain_crs_wkt` is refused with the ogr2ogr
/// command). Throws core::InputError(path, …) naming the line of a bad value, or when the
/// file holds no stop.
ObservedStops read_observed_stops(const std::string& path, const std::string& layer, const std::string& terrain_crs_wkt,
                                  const std::string& key);

}  // namespace talus::io
