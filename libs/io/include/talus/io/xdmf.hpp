// SPDX-License-Identifier: MIT
#pragma once
#include <cstddef>
#include <string>

namespace talus::io {

/// `text` with the characters XML reserves in attribute values and text (& < > ")
/// replaced by entities; for names written into any XDMF file.
std::string xml_escape(const std::string& text);

/// The sidecar path of a terrain file: the same path with the extension .xmf
/// ("slope.h5" → "slope.xmf").
std::string xdmf_sidecar_path(const std::string& h5_path);

/// XDMF 3 text describing the TRN of a terrain file so that ParaView (or VisIt) opens it
/// without Talus: Topology Triangle from /trn/triangles, Geometry XYZ from /trn/vertices,
/// and the cell attribute "material" from /trn/material. `h5_reference` is the terrain
/// file as the .xmf names it (its file name, so the two files move together).
std::string terrain_xdmf(const std::string& h5_reference, std::size_t vertex_count,
                         std::size_t triangle_count);

/// Writes the sidecar of the terrain file `h5_path` to `xmf_path`, atomically. The
/// reference to the HDF5 file is relative when both lie in the same directory.
void write_terrain_xdmf(const std::string& xmf_path, const std::string& h5_path,
                        std::size_t vertex_count, std::size_t triangle_count);

}  // namespace talus::io
