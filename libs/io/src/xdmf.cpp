#include "talus/io/xdmf.hpp"

#include <filesystem>

#include "talus/io/atomic_output.hpp"

namespace talus::io {
std::string xml_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string xdmf_sidecar_path(const std::string& h5_path) {
  return std::filesystem::path(h5_path).replace_extension(".xmf").string();
}

std::string terrain_xdmf(const std::string& h5_reference, std::size_t vertex_count,
                         std::size_t triangle_count) {
  const std::string file = xml_escape(h5_reference);
  const std::string n = std::to_string(vertex_count), m = std::to_string(triangle_count);
  return "<?xml version=\"1.0\" ?>\n"
         "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
         "<Xdmf Version=\"3.0\">\n"
         "  <Domain>\n"
         "    <Grid Name=\"terrain\" GridType=\"Uniform\">\n"
         "      <Topology TopologyType=\"Triangle\" NumberOfElements=\"" + m + "\">\n"
         "        <DataItem Dimensions=\"" + m + " 3\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" +
         file + ":/trn/triangles</DataItem>\n"
         "      </Topology>\n"
         "      <Geometry GeometryType=\"XYZ\">\n"
         "        <DataItem Dimensions=\"" + n + " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" +
         file + ":/trn/vertices</DataItem>\n"
         "      </Geometry>\n"
         "      <Attribute Name=\"material\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
         "        <DataItem Dimensions=\"" + m + "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" +
         file + ":/trn/material</DataItem>\n"
         "      </Attribute>\n"
         "    </Grid>\n"
         "  </Domain>\n"
         "</Xdmf>\n";
}

void write_terrain_xdmf(const std::string& xmf_path, const std::string& h5_path,
                        std::size_t vertex_count, std::size_t triangle_count) {
  namespace fs = std::filesystem;
  const fs::path xmf_dir = fs::path(xmf_path).parent_path();
  const fs::path h5_dir = fs::path(h5_path).parent_path();
  std::error_code ec;
  const bool same_dir = xmf_dir == h5_dir || fs::equivalent(xmf_dir.empty() ? "." : xmf_dir,
                                                             h5_dir.empty() ? "." : h5_dir, ec);
  const std::string reference =
      same_dir ? fs::path(h5_path).filename().string() : fs::absolute(h5_path).lexically_normal().string();
  write_text_file(xmf_path, terrain_xdmf(reference, vertex_count, triangle_count));
}

}  // namespace talus::io
