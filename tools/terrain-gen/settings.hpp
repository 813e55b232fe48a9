// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"
#include "talus/terrain/materials.hpp"
#include "talus/terrain/synthetic.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain_gen {

/// Everything terrain-gen reads from -c / --set, declared once (docs/terrain.md lists the
/// same fields). Coordinates in settings (crop window, zones) are input coordinates, before
/// the origin shift.
struct Settings {
  /// Input kind: auto infers it from the input extensions (none: synthetic).
  std::string source = "auto";
  std::string name;                 ///< terrain name; empty: from the inputs
  std::string crs;                  ///< EPSG:nnnn, WKT or .prj file; empty: the DEM's or LAS file's own
  std::uint64_t seed = 1;           ///< terrain seed: roughness realizations and random diagonals
  std::string triangulation = "alternating";  ///< fixed, alternating or random (grid terrains)
  terrain::SyntheticSlope synthetic;

  struct Crop {
    std::optional<double> xmin, ymin, xmax, ymax;  ///< m, input coordinates; absent = unbounded
    bool any() const { return xmin || ymin || xmax || ymax; }
    void visit(core::SettingsVisitor& v);
  } crop;

  struct Tin {
    std::string mode = "keep";  ///< keep the surveyed TIN or resample it to a grid
    double cell_size = 1.0;     ///< m, grid spacing when resampling
    std::string up_axis = "z";  ///< z or y: which input axis points up
    double scale = 1.0;         ///< -, multiplies input coordinates (0.001 for mm)
    std::vector<double> las_classes;  ///< ASPRS classes of the LAS points kept (2: ground); empty: all
    void visit(core::SettingsVisitor& v);
  } tin;

  struct Origin {
    std::string mode = "auto";               ///< auto, none or given
    std::array<double, 3> shift{0, 0, 0};    ///< m, subtracted from input coordinates (mode given)
    void visit(core::SettingsVisitor& v);
  } origin;

  struct Roughness {
    std::optional<double> sigma;            ///< m, sd of the grid-point elevation shifts
    std::optional<double> roughness_index;  ///< -, Römkens–Wang R; σ = 0.8 R m
    void visit(core::SettingsVisitor& v);
  } roughness;

  std::vector<terrain::Material> materials = {terrain::Material{}};
  /// Material zones drawn in a GIS: the polygons of a vector layer (holes kept), in the
  /// DEM's CRS, each naming its material in a text field.
  struct ZoneFile {
    std::string file;                         ///< GeoPackage, GeoJSON, Shapefile …; empty: none
    std::string layer;                        ///< the file's layer; empty: its only layer
    std::string material_field = "material";  ///< text field naming each polygon's material
    void visit(core::SettingsVisitor& v);
  } zone_file;
  std::vector<terrain::MaterialZone> zones;
  std::string material_raster;  ///< .asc/.tif of material ids (indices into the materials)

  void visit(core::SettingsVisitor& v);
};

}  // namespace talus::terrain_gen
