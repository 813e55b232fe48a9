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

/// Writes `dem` as an ESRI ASCII grid with xllcenter/yllcenter keys (the grid points
/// themselves, so no half-cell arithmetic can round) and cellsize, or dx and dy when they
/// differ. NaN is written as `nodata`. Numbers are written with the fewest digits that
/// read back to the same double, so a write–read round trip is exact. Atomic.
void write_esri_ascii(const std::string& path, const terrain::DemGrid& dem, double nodata = -9999.0);

/// Writes `dem` as a north-up, DEFLATE-compressed Float64 GeoTIFF; NaN is written as
/// `nodata` and declared as the band's nodata value. `crs_wkt` (optional) is stored as the
/// spatial reference. A write–read round trip is exact. Atomic (io::AtomicOutput).
void write_geotiff(const std::string& path, const terrain::DemGrid& dem, double nodata = -9999.0,
                   const std::string& crs_wkt = {});

}  // namespace talus::io
