#include "settings.hpp"

namespace talus::terrain_gen {

void Settings::Crop::visit(core::SettingsVisitor& v) {
  v.bounded("xmin", xmin, "m", "west edge of the window kept (input coordinates); null = unbounded", core::Range::symmetric(1e9));
  v.bounded("ymin", ymin, "m", "south edge of the window kept; null = unbounded", core::Range::symmetric(1e9));
  v.bounded("xmax", xmax, "m", "east edge of the window kept; null = unbounded", core::Range::symmetric(1e9));
  v.bounded("ymax", ymax, "m", "north edge of the window kept; null = unbounded", core::Range::symmetric(1e9));
}

void Settings::Tin::visit(core::SettingsVisitor& v) {
  v.choice("mode", mode, {"keep", "resample"},
           "keep the surveyed TIN as a general surface (walls, overhangs) or resample it to a grid");
  v.bounded("cell_size", cell_size, "m", "grid spacing when mode is resample", core::Range::positive(1e4));
  v.choice("up_axis", up_axis, {"z", "y"}, "input axis that points up in meshes and point clouds");
  v.bounded("scale", scale, "-", "factor applied to mesh and point coordinates (0.001 for millimetres)",
            core::Range::positive(1e6));
  v.field("las_classes", las_classes, "-",
          "LAS files: keep only the points of these ASPRS classification codes, integers 0 to 255 (2 ground, 3-5 "
          "vegetation, 6 building, 7 low noise, 9 water); [2] keeps the ground; empty: every point");
}

void Settings::Origin::visit(core::SettingsVisitor& v) {
  v.choice("mode", mode, {"auto", "none", "given"},
           "auto: subtract the lower-left corner rounded down to 1 km when |x| or |y| exceeds 1e5 m; "
           "given: subtract shift");
  v.bounded("shift", shift, "m", "[x, y, z] subtracted from input coordinates when mode is given",
            core::Range::symmetric(1e9));
}

void Settings::ZoneFile::visit(core::SettingsVisitor& v) {
  v.field("file", file,
          "vector file of material zones (GeoPackage, GeoJSON, Shapefile ...: Polygon and MultiPolygon features, "
          "holes kept) in the DEM's CRS and coordinates; empty: none");
  v.field("layer", layer, "layer of the file; empty: its only layer");
  v.field("material_field", material_field, "text field naming the material of each polygon (a materials name)");
}

void Settings::Roughness::visit(core::SettingsVisitor& v) {
  v.bounded("sigma", sigma, "m", "standard deviation of the grid-point elevation shifts; null = smooth",
            core::Range::closed(0.0, 100.0));
  v.bounded("roughness_index", roughness_index, "-",
            "Roemkens-Wang roughness index R instead of sigma (sigma = 0.8 R m: 1/8, 1/4, 1/2 give 0.1, 0.2, 0.4 m)",
            core::Range::closed(0.0, 125.0));
}

void Settings::visit(core::SettingsVisitor& v) {
  v.choice("source", source, {"auto", "synthetic", "dem", "tin", "points"},
           "input kind; auto: from the input extensions (.asc/.tif: dem; .xyz/.txt/.pts/.csv, .las and .ply "
           "without faces: points; .stl/.obj/.ply/.off/.gltf/.glb: tin; no input: synthetic)");
  v.field("name", name, "terrain name recorded in the file; empty: from the inputs");
  v.field("crs", crs,
          "coordinate reference system of the input coordinates: EPSG:nnnn, WKT or a .prj file; empty: the "
          "DEM's own (GeoTIFF spatial reference, or the .prj beside an .asc) or the LAS file's (WKT or GeoTIFF "
          "EPSG code), none for meshes, text point clouds and synthetic slopes. Projected, in metres; "
          "geographic CRSs are refused");
  v.field("seed", seed, "-", "terrain seed: realization i of the roughness is a pure function of (seed, i)");
  v.choice("triangulation", triangulation, {"fixed", "alternating", "random"},
           "diagonal of each grid cell; fixed reproduces the reference model's one-sided cut");
  v.section("synthetic", "synthetic slope (source synthetic)", [this](core::SettingsVisitor& s) { synthetic.visit(s); });
  v.section("crop", "window kept from the input, input coordinates", [this](core::SettingsVisitor& s) { crop.visit(s); });
  v.section("tin", "surveyed surfaces: meshes (one file per material) and point clouds",
            [this](core::SettingsVisitor& s) { tin.visit(s); });
  v.section("origin", "shift of the coordinate origin (large projected coordinates lose precision)",
            [this](core::SettingsVisitor& s) { origin.visit(s); });
  v.section("roughness", "ground roughness: give sigma or roughness_index, not both",
            [this](core::SettingsVisitor& s) { roughness.visit(s); });
  v.list_of("materials",
            "ground materials; material 0 covers everything no zone, raster or mesh file assigns. With meshes, "
            "each file takes the material named like the file (scree.stl: 'scree')",
            materials);
  v.section("zone_file",
            "material zones from a vector file, applied after material_raster and before zones (later polygons win)",
            [this](core::SettingsVisitor& s) { zone_file.visit(s); });
  // Zones are read in input coordinates (the library's MaterialZone speaks of local ones):
  // users draw them on the map, before any origin shift.
  v.list("zones", "plan polygons assigning a material; later zones win",
         {[this] { return zones.size(); }, [this](std::size_t n) { zones.resize(n); },
          [this](std::size_t i, core::SettingsVisitor& z) {
            z.field("material", zones[i].material, "name of the material of this zone");
            z.field("polygon", zones[i].polygon, "m",
                    "zone outline in plan, [x, y] points in input coordinates (at least 3)");
          }});
  v.field("material_raster", material_raster,
          "raster (.asc/.tif, input coordinates) of material ids, indices into materials; empty: none");
}

}  // namespace talus::terrain_gen
