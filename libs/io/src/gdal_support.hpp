// SPDX-License-Identifier: MIT
#pragma once
// GDAL helpers shared by the raster and vector readers and writers of talus_io. Internal
// to the library: GDAL's headers stay out of the public headers, so the code that
// includes talus/io does not see them.
#include <cpl_error.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include <memory>
#include <string>
#include <type_traits>

namespace talus::io::gdal {

/// Registers GDAL's drivers once per process.
void register_drivers();

/// GDAL reports problems through a global handler that prints to stderr; Talus reports
/// one line instead, with GDAL's last message appended. Held for the duration of a call.
class Quiet {
 public:
  Quiet();
  ~Quiet();
  Quiet(const Quiet&) = delete;
  Quiet& operator=(const Quiet&) = delete;
  /// " (GDAL's last message)", or "" when there is none.
  static std::string last_message();
};

struct DatasetCloser {
  void operator()(void* ds) const {
    if (ds) GDALClose(static_cast<GDALDatasetH>(ds));
  }
};
using DatasetPtr = std::unique_ptr<void, DatasetCloser>;

struct SrsCloser {
  void operator()(OGRSpatialReferenceH srs) const {
    if (srs) OSRDestroySpatialReference(srs);
  }
};
using SrsPtr = std::unique_ptr<std::remove_pointer_t<OGRSpatialReferenceH>, SrsCloser>;

/// The text and frees it with CPLFree.
std::string take_string(char* text);

/// "WGS 84 / UTM zone 32N (EPSG:32632)".
std::string name_of(OGRSpatialReferenceH srs);

/// The CRS of `text` (EPSG:nnnn, WKT, a PROJ string) with EPSG codes filled in where
/// GDAL recognises the definition (an ESRI .prj names none), in the traditional GIS axis
/// order (x = easting); null when GDAL cannot read it.
SrsPtr parse_srs(const std::string& text);

/// A copy of `srs` completed as parse_srs completes a definition without a code.
SrsPtr identified(OGRSpatialReferenceH srs);

}  // namespace talus::io::gdal
