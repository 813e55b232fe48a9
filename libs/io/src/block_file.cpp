#include "talus/io/block_file.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "talus/core/error.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/geometry/polyhedron.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/xdmf.hpp"

namespace talus::io {

using geometry::Mat3;
using geometry::Vec3;

namespace {

std::string group_name(std::size_t i) {
  char name[32];
  std::snprintf(name, sizeof name, "block_%04zu", i);
  return name;
}

void write_vec(const h5::Group& g, const std::string& name, const Vec3& v, std::string_view unit) {
  g.write(name, v.data(), {3}, unit);
}

// Eigen matrices are column-major; files are row-major.
void write_mat(const h5::Group& g, const std::string& name, const Mat3& m, std::string_view unit) {
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> r = m;
  g.write(name, r.data(), {3, 3}, unit);
}

Vec3 read_vec(const h5::Group& g, const std::string& name) {
  const std::vector<double> v = g.read_doubles(name, {3});
  return Vec3(v[0], v[1], v[2]);
}

Mat3 read_mat(const h5::Group& g, const std::string& name) {
  const std::vector<double> v = g.read_doubles(name, {3, 3});
  Mat3 m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = v[static_cast<std::size_t>(3 * i + j)];
  return m;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  return out;
}

}  // namespace

void write_block_file(const std::string& path, const std::vector<block::Block>& blocks,
                      const Provenance& provenance, const std::string& xdmf_path) {
  AtomicOutput out(path);
  {
    h5::File file = h5::File::create(out.temp_path(), path);
    const h5::Group root = file.root();
    write_header(root, "block", kBlockSchema, provenance);
    const h5::Group lib = root.create_group("blocks");
    lib.set_attr("count", static_cast<std::int64_t>(blocks.size()));
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      const block::Block& b = blocks[i];
      const h5::Group g = lib.create_group(group_name(i));
      g.set_attr("name", b.name);
      g.set_attr("source", b.source);
      g.set_attr("notes", join_lines(b.notes));
      g.set_attr("volume_rational", b.volume_rational);
      const std::vector<std::pair<const char*, double>> scalars{
          {"volume_exact", b.volume_exact}, {"volume", b.volume},     {"surface_area", b.surface_area},
          {"sphericity", b.sphericity},     {"density", b.density},   {"mass", b.mass},
          {"weight", b.weight}};
      for (const auto& [name, value] : scalars) g.set_attr(name, value);

      const auto& poly = b.polyhedron;
      std::vector<double> xyz;
      for (const Vec3& p : poly.vertices) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
      std::vector<std::int32_t> offsets{0}, indices;
      for (const auto& face : poly.faces) {
        indices.insert(indices.end(), face.begin(), face.end());
        offsets.push_back(static_cast<std::int32_t>(indices.size()));
      }
      const geometry::TriangleMesh tri = geometry::triangulate(poly);
      std::vector<std::int32_t> triangles;
      for (const auto& t : tri.triangles) triangles.insert(triangles.end(), t.begin(), t.end());
      const bool big = poly.vertices.size() > 4096;
      g.write("vertices", xyz.data(), {poly.vertices.size(), 3}, "m", big);
      g.write("face_offsets", offsets.data(), {offsets.size()}, "-", big);
      g.write("face_vertices", indices.data(), {indices.size()}, "-", big);
      g.write("triangles", triangles.data(), {tri.triangles.size(), 3}, "-", big);
      write_vec(g, "centroid", b.centroid, "m");
      write_mat(g, "second_moments", b.second_moments, "m^5");
      write_mat(g, "inertia_per_density", b.inertia_per_density, "m^5");
      write_mat(g, "inertia", b.inertia, "kg m^2");
      write_vec(g, "principal_moments", b.principal_moments, "kg m^2");
      write_mat(g, "principal_axes", b.principal_axes, "-");
      write_vec(g, "dimensions", b.dimensions, "m");
      write_mat(g, "rotation", b.rotation, "-");
      write_vec(g, "translation", b.translation, "m");
    }
    file.close();
  }
  if (!xdmf_path.empty()) write_block_xdmf(xdmf_path, path, blocks);
  out.commit();
}

std::vector<block::Block> read_block_file(const std::string& path) {
  const h5::File file = h5::File::open(path);
  const h5::Group root = file.root();
  check_header(root, "block", kBlockSchema);
  const h5::Group lib = root.open_group("blocks");
  const auto count = lib.attr_int("count");
  if (count < 1) throw core::InputError(path, "block file holds no blocks");
  std::vector<block::Block> blocks;
  for (std::int64_t i = 0; i < count; ++i) {
    const std::string gname = group_name(static_cast<std::size_t>(i));
    const h5::Group g = lib.open_group(gname);
    const std::string where = path + " (" + gname + ")";
    block::Block b;
    b.name = g.attr_string("name");
    b.source = g.attr_string("source");
    std::istringstream notes(g.attr_string("notes"));
    for (std::string line; std::getline(notes, line);) b.notes.push_back(line);
    b.volume_rational = g.attr_string("volume_rational");
    b.volume_exact = g.attr_double("volume_exact");
    b.volume = g.attr_double("volume");
    b.surface_area = g.attr_double("surface_area");
    b.sphericity = g.attr_double("sphericity");
    b.density = g.attr_double("density");
    b.mass = g.attr_double("mass");
    b.weight = g.attr_double("weight");

    const std::vector<double> xyz = g.read_doubles("vertices", {0, 3});
    const std::vector<std::int32_t> offsets = g.read_int32("face_offsets", {0});
    const std::vector<std::int32_t> indices = g.read_int32("face_vertices", {0});
    for (std::size_t k = 0; k < xyz.size(); k += 3) b.polyhedron.vertices.emplace_back(xyz[k], xyz[k + 1], xyz[k + 2]);
    if (offsets.empty() || offsets.front() != 0 || offsets.back() != static_cast<std::int32_t>(indices.size()))
      throw core::InputError(where, "face_offsets do not match face_vertices");
    for (std::size_t f = 0; f + 1 < offsets.size(); ++f) {
      if (offsets[f + 1] < offsets[f]) throw core::InputError(where, "face_offsets are not increasing");
      b.polyhedron.faces.emplace_back(indices.begin() + offsets[f], indices.begin() + offsets[f + 1]);
    }
    geometry::HalfEdgeMesh he;
    const geometry::TopologyReport topo = geometry::HalfEdgeMesh::build(b.polyhedron.vertices, b.polyhedron.faces, he);
    if (!topo.ok()) throw core::InputError(where, "corrupt polyhedron: " + topo.describe());
    for (const Vec3& p : b.polyhedron.vertices)
      if (!p.allFinite()) throw core::InputError(where, "corrupt polyhedron: non-finite vertex");

    b.centroid = read_vec(g, "centroid");
    b.second_moments = read_mat(g, "second_moments");
    b.inertia_per_density = read_mat(g, "inertia_per_density");
    b.inertia = read_mat(g, "inertia");
    b.principal_moments = read_vec(g, "principal_moments");
    b.principal_axes = read_mat(g, "principal_axes");
    b.dimensions = read_vec(g, "dimensions");
    b.rotation = read_mat(g, "rotation");
    b.translation = read_vec(g, "translation");
    if (!(b.volume > 0.0) || !(b.density > 0.0) || !(b.weight >= 0.0) || !std::isfinite(b.weight))
      throw core::InputError(where, "corrupt block: volume and density must be positive, weight non-negative");
    if (!std::isfinite(b.volume) || !std::isfinite(b.mass) || !std::isfinite(b.density) || !b.inertia.allFinite() ||
        !b.centroid.allFinite() || !b.rotation.allFinite() || !b.translation.allFinite())
      throw core::InputError(where, "corrupt block: a property is not finite");
    // The polyhedron must enclose the volume the file states (inverted faces give a
    // negative one), so the engine never meets a block the file misdescribes.
    const double enclosed = geometry::mass_properties(b.polyhedron).volume;
    if (!(enclosed > 0.0) || std::abs(enclosed - b.volume) > 1e-6 * b.volume)
      throw core::InputError(where, "corrupt block: the polyhedron encloses " + core::format_number(enclosed) +
                                        " m^3, the file states volume " + core::format_number(b.volume) + " m^3");
    // The stated properties must agree with the polyhedron they describe.
    const auto close = [](double value, double reference) {
      return std::abs(value - reference) <= 1e-6 * std::abs(reference);
    };
    if (!std::isfinite(b.volume_exact) || !close(b.volume_exact, enclosed))
      throw core::InputError(where, "corrupt block: volume_exact is " + core::format_number(b.volume_exact) +
                                        " m^3, the polyhedron encloses " + core::format_number(enclosed) + " m^3");
    if (!(b.mass > 0.0) || !close(b.mass, b.density * b.volume_exact))
      throw core::InputError(where, "corrupt block: mass is " + core::format_number(b.mass) + " kg, density x volume is " +
                                        core::format_number(b.density * b.volume_exact) + " kg");
    if (!(b.surface_area > 0.0) || !std::isfinite(b.surface_area) || !(b.sphericity > 0.0) || !(b.sphericity <= 1.0 + 1e-9))
      throw core::InputError(where, "corrupt block: surface_area must be positive and finite, sphericity in (0, 1]");
    for (const auto& earlier : blocks)
      if (earlier.name == b.name)
        throw core::InputError(where, "corrupt block file: two blocks are named '" + b.name +
                                          "' (names are unique in a block file)");
    blocks.push_back(std::move(b));
  }
  return blocks;
}

void write_block_xdmf(const std::string& xdmf_path, const std::string& h5_path,
                      const std::vector<block::Block>& blocks) {
  // The sidecar refers to the HDF5 file by a path relative to itself.
  const std::filesystem::path dir = std::filesystem::path(xdmf_path).parent_path();
  std::string h5 = std::filesystem::path(h5_path).filename().string();
  if (!dir.empty() && std::filesystem::path(h5_path).parent_path() != dir)
    h5 = std::filesystem::relative(std::filesystem::absolute(h5_path), std::filesystem::absolute(dir)).string();
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
    << "  <Grid Name=\"blocks\" GridType=\"Collection\" CollectionType=\"Spatial\">\n";
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const block::Block& b = blocks[i];
    const std::string g = "/blocks/" + group_name(i);
    const geometry::TriangleMesh tri = geometry::triangulate(b.polyhedron);
    x << "   <Grid Name=\"" << xml_escape(b.name) << "\" GridType=\"Uniform\">\n"
      << "    <Topology TopologyType=\"Triangle\" NumberOfElements=\"" << tri.triangles.size() << "\">\n"
      << "     <DataItem Dimensions=\"" << tri.triangles.size() << " 3\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">"
      << h5 << ":" << g << "/triangles</DataItem>\n    </Topology>\n"
      << "    <Geometry GeometryType=\"XYZ\">\n"
      << "     <DataItem Dimensions=\"" << b.polyhedron.vertices.size()
      << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << h5 << ":" << g << "/vertices</DataItem>\n"
      << "    </Geometry>\n   </Grid>\n";
  }
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  write_text_file(xdmf_path, x.str());
}

std::string describe_block(const block::Block& b) {
  char buf[512];
  std::string s;
  auto line = [&](const char* fmt, auto... args) {
    std::snprintf(buf, sizeof buf, fmt, args...);
    s += buf;
  };
  line("block '%s' (from %s)\n", b.name.c_str(), b.source.c_str());
  std::size_t max_face = 0;
  for (const auto& f : b.polyhedron.faces) max_face = std::max(max_face, f.size());
  line("  vertices %zu, faces %zu (up to %zu-gons)\n", b.polyhedron.vertices.size(), b.polyhedron.faces.size(),
       max_face);
  line("  volume             %.15g m^3 (exact), %.15g m^3 (double)\n", b.volume_exact, b.volume);
  line("  surface area       %.10g m^2\n", b.surface_area);
  line("  sphericity         %.6f\n", b.sphericity);
  line("  L1 >= L2 >= L3     %.6g, %.6g, %.6g m\n", b.dimensions[0], b.dimensions[1], b.dimensions[2]);
  line("  density            %.6g kg/m^3, mass %.10g kg, weight %.6g\n", b.density, b.mass, b.weight);
  line("  centroid (input)   %.10g, %.10g, %.10g m\n", b.centroid[0], b.centroid[1], b.centroid[2]);
  line("  principal moments  %.10g, %.10g, %.10g kg m^2\n", b.principal_moments[0], b.principal_moments[1],
       b.principal_moments[2]);
  for (int c = 0; c < 3; ++c)
    line("  principal axis %d   (%.6f, %.6f, %.6f)\n", c + 1, b.principal_axes(0, c), b.principal_axes(1, c),
         b.principal_axes(2, c));
  line("  inertia            [%.10g %.10g %.10g; %.10g %.10g %.10g; %.10g %.10g %.10g] kg m^2\n", b.inertia(0, 0),
       b.inertia(0, 1), b.inertia(0, 2), b.inertia(1, 0), b.inertia(1, 1), b.inertia(1, 2), b.inertia(2, 0),
       b.inertia(2, 1), b.inertia(2, 2));
  for (const auto& n : b.notes) s += "  note: " + n + "\n";
  return s;
}

}  // namespace talus::io
