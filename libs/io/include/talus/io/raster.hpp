// SPDX-License-Identifier: MIT
#pragma once
#include <string>

#include "talus/terrain/terrain.hpp"

namespace talus::io {

/// Reads an ESRI ASCII grid (.asc). Header keys, in any order and any letter case:
/// ncols, nrows (> 0); xllcorner or xllcenter; yllcorner or yllcenter; cellsize (> 0), or
/// dx and dy (> 0); NODATA_value (optional). Values follow row by row from north to south,
/// separated by any white space. Grid points are cell centres: for a *corner key the first
/// point lies half a cell inside the corner. Values equal to NODATA_value become NaN.
/// Every malformed file (missing, duplicate or unknown key, non-numeric or non-finite
/// value, too few or too many values, bad sizes) throws core::InputError naming the file
/// and the line ("dem.asc:7: ...").
terrain::DemGrid read_esri_ascii(const std::string& path);

/// Reads band 1 of a GeoTIFF (or any single-band raster GDAL opens) as a DEM. The
/// geotransform must be axis-aligned (no rotation terms); rows may run north to south
/// (negative pixel height, the usual case) or south to north. Grid points are pixel
/// centres; the band's nodata value and NaN become NaN. Throws core::InputError naming
/// the file on anything else.
terrain::DemGrid read_geotiff(const std::string& path);

/// Reads a DEM chosen by extension: .asc as ESRI ASCII, .tif/.tiff as GeoTIFF.
terrain::DemGrid read_dem(const std::string& path);

/// The GDAL this build reads rasters with and its GeoTIFF support, for --version:
/// "GDAL 3.6.2 (GeoTIFF read/write)".
std::string gdal_description();

/// True when `path` names a raster read_dem understands (.asc, .tif, .tiff, any case).
bool is_dem_path(const std::string& path);

/// The coordinate reference system a DEM file declares, as the user wrote it (`text`): a
/// GeoTIFF's spatial reference (WKT), or the text of the `.prj` file beside an `.asc`
/// (same name, extension .prj or .PRJ; blank lines and spaces around it taken off), and
/// the file that holds it (`file`, for messages). Empty when the file declares none.
/// Throws core::InputError naming the file when it cannot be read.
struct DemCrs {
  std::string text, file;
};
DemCrs dem_crs(const std::string& path);

/// What a CRS describes, for the command a refusal suggests to reproject it.
enum class CrsData { raster, point_cloud };

/// A coordinate reference system given as "EPSG:nnnn", WKT (1 or 2, or ESRI's, as in
/// `.prj` files) or a PROJ string, checked and returned as WKT. Talus computes in metres
/// on a plane: a geographic CRS (degrees) or a projected one whose unit is not the metre
/// is refused, with the command that reprojects the data (`gdalwarp` for a DEM, `pdal
/// translate` for a point cloud). Throws core::InputError naming `source` (the file or
/// setting the CRS came from).
std::string resolve_crs(const std::string& text, const std::string& source, CrsData data = CrsData::raster);

/// A short name of a CRS given as WKT, "WGS 84 / UTM zone 32N (EPSG:32632)"; "none"
/// when `wkt` is empty.
std::string crs_name(const std::string& wkt);

/// Writes `wkt` in the ESRI form of a `.prj` file at `path` (atomic). Nothing when empty.
void write_prj(const std::string& path, const std::string& wkt);

/// Writes `dem` as an ESRI ASCII grid with xllcenter/yllcenter keys (the grid points
/// themselves, so no half-cell arithmetic can round) and cellsize, or dx and dy when they
/// differ. NaN is written as `nodata`. Numbers are written with the fewest digits that
/// read back to the same double, so a write–read round trip is exact. Atomic.
void write_esri_ascii(const std::string& path, const terrain::DemGrid& dem, double nodata = -9999.0);

/// What a raster band is: its description (GDAL's band description, shown by GIS
/// software as the band name) and its unit (GDAL's unit type, e.g. "J", "m", "1").
struct BandInfo {
  std::string description;
  std::string unit;
  bool integer = false;  ///< whole numbers (counts): written as an Int32 band
};

/// Writes `dem` as a north-up, DEFLATE-compressed Float64 GeoTIFF (Int32 for an integer `band`); NaN is written as
/// `nodata` and declared as the band's nodata value. `crs_wkt` (optional) is stored as the
/// spatial reference, `band` (optional) as the band's description and unit. A write–read
/// round trip is exact. Atomic (io::AtomicOutput).
void write_geotiff(const std::string& path, const terrain::DemGrid& dem, double nodata = -9999.0,
                   const std::string& crs_wkt = {}, const BandInfo& band = {});

/// The description and unit of a raster's first band ("" where none is set).
BandInfo read_band_info(const std::string& path);

}  // namespace talus::io
