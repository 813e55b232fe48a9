#include "talus/io/terrain_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>
#include <vector>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/xdmf.hpp"

namespace talus::io {
namespace {

using core::InputError;
using terrain::GridSpec;
using terrain::Material;
using terrain::Terrain;

std::string count_text(std::size_t n) { return std::to_string(n); }

// Material parameters as stored, one dataset per column: name, value accessor, unit
// (their allowed values are Material::ranges()).
struct MaterialColumn {
  const char* name;
  double Material::*field;
  const char* unit;
  // Added after the format's first version: absent from earlier files, read as the
  // default, and left out of the fingerprint at its default so theirs stays as it was.
  bool optional = false;
};
constexpr MaterialColumn kMaterialColumns[] = {
    {"restitution_mean", &Material::restitution_mean, "-"},
    {"restitution_sd", &Material::restitution_sd, "-"},
    {"restitution_scale", &Material::restitution_scale, "m/s"},
    {"friction_angle_mean_deg", &Material::friction_angle_mean_deg, "deg"},
    {"friction_coefficient_sd", &Material::friction_coefficient_sd, "-"},
    {"lateral_tilt_sd_deg", &Material::lateral_tilt_sd_deg, "deg"},
    {"ploughing", &Material::ploughing, "-", true},
};

}  // namespace

// Shared by the writer (where a problem is a caller bug), the reader (a corrupt file) and
// terrain-gen (bad settings).
std::string terrain_problem(const Terrain& t) {
  const auto& mesh = t.mesh;
  if (t.materials.empty()) return "no materials";
  if (mesh.vertices.empty()) return "no vertices";
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (!mesh.vertices[v].allFinite()) return "vertex " + count_text(v) + " is not finite";
    else if (mesh.vertices[v].cwiseAbs().maxCoeff() > 1e9) return "vertex " + count_text(v) + " lies beyond 1e9 m";
  const auto n = static_cast<std::int64_t>(mesh.vertices.size());
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k)
    for (std::int32_t v : mesh.triangles[k])
      if (v < 0 || v >= n)
        return "triangle " + count_text(k) + " has vertex index " + std::to_string(v) + " out of range [0, " +
               std::to_string(n) + ")";
  const auto materials = static_cast<std::int32_t>(t.materials.size());
  for (std::size_t k = 0; k < t.material_of_triangle.size(); ++k) {
    const std::int32_t m = t.material_of_triangle[k];
    if (m < 0 || m >= materials)
      return "triangle " + count_text(k) + " has material id " + std::to_string(m) + " out of range [0, " +
             std::to_string(materials) + ")";
  }
  // The ranges terrain-gen and dda-run read materials with (parallel to kMaterialColumns).
  const Material::Ranges r = Material::ranges();
  const core::Range* ranges[] = {&r.restitution_mean,        &r.restitution_sd,         &r.restitution_scale,
                                 &r.friction_angle_mean_deg, &r.friction_coefficient_sd, &r.lateral_tilt_sd_deg,
                                 &r.ploughing};
  static_assert(std::size(kMaterialColumns) == 7);
  for (const Material& m : t.materials)
    for (std::size_t c = 0; c < std::size(kMaterialColumns); ++c) {
      const double value = m.*(kMaterialColumns[c].field);
      if (!ranges[c]->contains(value))
        return "material '" + m.name + "': " + kMaterialColumns[c].name + " = " + core::format_number(value) +
               " is outside " + ranges[c]->text(kMaterialColumns[c].unit);
    }
  if (!(t.roughness.sigma >= 0.0 && t.roughness.sigma <= 100.0))
    return "roughness sigma = " + core::format_number(t.roughness.sigma) + " is outside [0, 100] m";
  if (!t.origin_shift.allFinite()) return "origin_shift is not finite";
  if (t.grid) {
    const GridSpec& g = *t.grid;
    if (g.nx < 2 || g.ny < 2) return "grid needs at least 2 x 2 points";
    if (!(std::isfinite(g.x0) && std::isfinite(g.y0) && g.dx > 0.0 && g.dy > 0.0 && std::isfinite(g.dx) &&
          std::isfinite(g.dy)))
      return "grid origin and spacing must be finite with dx, dy > 0";
    if (mesh.vertices.size() != g.point_count())
      return "grid of " + count_text(g.point_count()) + " points has " + count_text(mesh.vertices.size()) + " vertices";
    if (t.cell_diagonal.size() != g.cell_count())
      return "grid of " + count_text(g.cell_count()) + " cells has " + count_text(t.cell_diagonal.size()) +
             " diagonals";
    for (std::size_t c = 0; c < t.cell_diagonal.size(); ++c)
      if (t.cell_diagonal[c] > 1) return "cell " + count_text(c) + " has diagonal code " + std::to_string(t.cell_diagonal[c]);
    if (!mesh.triangles.empty() && mesh.triangles.size() != 2 * g.cell_count())
      return "grid of " + count_text(g.cell_count()) + " cells has " + count_text(mesh.triangles.size()) + " triangles";
    if (!t.material_of_triangle.empty() && t.material_of_triangle.size() != 2 * g.cell_count())
      return "grid of " + count_text(g.cell_count()) + " cells has " + count_text(t.material_of_triangle.size()) +
             " material ids";
  } else {
    if (mesh.triangles.empty()) return "no triangles";
    if (t.material_of_triangle.size() != mesh.triangles.size())
      return count_text(mesh.triangles.size()) + " triangles have " + count_text(t.material_of_triangle.size()) +
             " material ids";
  }
  return {};
}

namespace {

// The triangles of a grid TRN as the engine sees them (Surface vertex order), so the file
// and the engine agree by construction.
std::vector<std::array<std::int32_t, 3>> grid_triangles(const Terrain& t) {
  const terrain::Surface base = terrain::Surface::realize(t, std::nullopt);
  std::vector<std::array<std::int32_t, 3>> triangles(base.triangle_count());
  for (std::size_t k = 0; k < triangles.size(); ++k) triangles[k] = base.triangle(k);
  return triangles;
}

// Points and index triples are stored as they lie in memory: [n x 3] without a copy.
static_assert(sizeof(geometry::Vec3) == 3 * sizeof(double));
static_assert(sizeof(std::array<std::int32_t, 3>) == 3 * sizeof(std::int32_t));

std::uint64_t u64(std::size_t n) { return static_cast<std::uint64_t>(n); }

}  // namespace

void write_terrain_file(const std::string& path, const Terrain& terrain, const Provenance& provenance,
                        std::optional<double> roughness_index, const std::string& xdmf_path) {
  if (const std::string problem = terrain_problem(terrain); !problem.empty())
    throw core::RuntimeError(path + ": refusing to write an inconsistent terrain: " + problem);
  std::vector<std::array<std::int32_t, 3>> generated;
  if (terrain.grid) {
    generated = grid_triangles(terrain);
    if (!terrain.mesh.triangles.empty() && terrain.mesh.triangles != generated)
      throw core::RuntimeError(path + ": refusing to write a grid terrain whose triangles differ from its grid");
  }
  const auto& triangles = terrain.grid ? generated : terrain.mesh.triangles;
  const auto& vertices = terrain.mesh.vertices;
  std::vector<std::int32_t> zeros;
  if (terrain.material_of_triangle.empty()) zeros.assign(triangles.size(), 0);
  const auto& material = terrain.material_of_triangle.empty() ? zeros : terrain.material_of_triangle;

  AtomicOutput out(path);
  {
    h5::File file = h5::File::create(out.temp_path(), path);
    const h5::Group root = file.root();
    write_header(root, "terrain", kTerrainSchema, provenance);
    root.set_attr("name", terrain.name);
    root.set_attr("kind", terrain.grid ? "grid" : "tin");
    if (!terrain.crs_wkt.empty()) root.set_attr("crs_wkt", terrain.crs_wkt);
    root.write("origin_shift", terrain.origin_shift.data(), {3}, "m");

    const h5::Group g_trn = root.create_group("trn");
    g_trn.write("vertices", vertices.front().data(), {u64(vertices.size()), 3}, "m", true);
    g_trn.write("triangles", triangles.front().data(), {u64(triangles.size()), 3}, {}, true);
    g_trn.write("material", material.data(), {u64(material.size())}, {}, true);

    if (terrain.grid) {
      const GridSpec& s = *terrain.grid;
      const h5::Group g = root.create_group("grid");
      g.set_attr("x0", s.x0);
      g.set_attr("y0", s.y0);
      g.set_attr("dx", s.dx);
      g.set_attr("dy", s.dy);
      g.set_attr("nx", std::int64_t{s.nx});
      g.set_attr("ny", std::int64_t{s.ny});
      std::vector<double> z(s.point_count());
      for (std::size_t k = 0; k < z.size(); ++k) z[k] = terrain.mesh.vertices[k].z();
      g.write("z", z.data(), {u64(s.ny), u64(s.nx)}, "m", true);
      g.write("diagonal", terrain.cell_diagonal.data(), {u64(s.ny - 1), u64(s.nx - 1)}, {}, true);
    }

    const h5::Group g_mat = root.create_group("materials");
    std::vector<std::string> names;
    for (const auto& m : terrain.materials) names.push_back(m.name);
    g_mat.write_strings("name", names);
    std::vector<std::string> classes;
    for (const auto& m : terrain.materials) classes.push_back(m.class_name);
    g_mat.write_strings("class", classes);
    for (const auto& c : kMaterialColumns) {
      std::vector<double> column;
      for (const auto& m : terrain.materials) column.push_back(m.*(c.field));
      g_mat.write(c.name, column.data(), {u64(column.size())}, c.unit);
    }

    const h5::Group g_rough = root.create_group("roughness");
    g_rough.set_attr("sigma", terrain.roughness.sigma);
    // The seed is a 64-bit pattern; int64 storage keeps every bit.
    g_rough.set_attr("seed", static_cast<std::int64_t>(terrain.roughness.seed));
    if (roughness_index) g_rough.set_attr("roughness_index", *roughness_index);
    file.close();
  }
  if (!xdmf_path.empty()) write_terrain_xdmf(xdmf_path, path, vertices.size(), terrain.mesh.triangles.size());
  out.commit();
}

terrain::Terrain read_terrain_file(const std::string& path) {
  TerrainFileInfo info;
  return read_terrain_file(path, info);
}

void check_terrain_file(const std::string& path) {
  const h5::File file = h5::File::open(path);
  check_header(file.root(), "terrain", kTerrainSchema);
}

terrain::Terrain read_terrain_file(const std::string& path, TerrainFileInfo& info) {
  const h5::File file = h5::File::open(path);
  const h5::Group root = file.root();
  info.version = check_header(root, "terrain", kTerrainSchema);
  info.provenance = read_provenance(root);

  Terrain t;
  t.name = root.has_attr("name") ? root.attr_string("name") : "";
  t.crs_wkt = root.has_attr("crs_wkt") ? root.attr_string("crs_wkt") : "";
  const std::string kind = root.attr_string("kind");
  if (kind != "grid" && kind != "tin") throw InputError(path, "unknown terrain kind '" + kind + "' (expected grid or tin)");
  const auto shift = root.read_doubles("origin_shift", {3});
  t.origin_shift = geometry::Vec3(shift[0], shift[1], shift[2]);

  // One flat array at a time, each released once copied: the peak stays near the size
  // of the terrain itself.
  const h5::Group g_trn = root.open_group("trn");
  {
    const auto vertices = g_trn.read_doubles("vertices", {0, 3});
    t.mesh.vertices.resize(vertices.size() / 3);
    if (!vertices.empty()) std::copy(vertices.begin(), vertices.end(), t.mesh.vertices.front().data());
  }
  {
    const auto triangles = g_trn.read_int32("triangles", {0, 3});
    t.mesh.triangles.resize(triangles.size() / 3);
    if (!triangles.empty()) std::copy(triangles.begin(), triangles.end(), t.mesh.triangles.front().data());
  }
  const std::size_t n_tri = t.mesh.triangles.size();
  t.material_of_triangle = g_trn.read_int32("material", {u64(n_tri)});

  if (kind == "grid") {
    const h5::Group g = root.open_group("grid");
    GridSpec s;
    s.x0 = g.attr_double("x0");
    s.y0 = g.attr_double("y0");
    s.dx = g.attr_double("dx");
    s.dy = g.attr_double("dy");
    const std::int64_t nx = g.attr_int("nx"), ny = g.attr_int("ny");
    if (nx < 2 || ny < 2 || nx > (std::int64_t{1} << 30) || ny > (std::int64_t{1} << 30) ||
        nx * ny > (std::int64_t{1} << 30))
      throw InputError(path, "/grid has an invalid size " + std::to_string(nx) + " x " + std::to_string(ny));
    s.nx = static_cast<std::int32_t>(nx);
    s.ny = static_cast<std::int32_t>(ny);
    t.grid = s;
    const auto z = g.read_doubles("z", {u64(s.ny), u64(s.nx)});
    t.cell_diagonal = g.read_uint8("diagonal", {u64(s.ny - 1), u64(s.nx - 1)});
    if (t.mesh.vertices.size() != s.point_count())
      throw InputError(path, "/trn/vertices has " + count_text(t.mesh.vertices.size()) + " rows for a grid of " +
                                 count_text(s.point_count()) + " points");
    if (n_tri != 2 * s.cell_count())
      throw InputError(path, "/trn/triangles has " + count_text(n_tri) + " rows for a grid of " +
                                 count_text(s.cell_count()) + " cells (expected two per cell)");
    // NaN is left to the finiteness check below, which names the vertex.
    for (std::size_t k = 0; k < z.size(); ++k)
      if (z[k] != t.mesh.vertices[k].z() && !(std::isnan(z[k]) && std::isnan(t.mesh.vertices[k].z())))
        throw InputError(path, "/grid/z differs from /trn/vertices at point " + count_text(k));
  }

  const h5::Group g_mat = root.open_group("materials");
  const auto names = g_mat.read_strings("name");
  t.materials.resize(names.size());
  for (std::size_t m = 0; m < names.size(); ++m) t.materials[m].name = names[m];
  if (g_mat.has("class")) {  // absent in files of earlier versions: "none"
    const auto classes = g_mat.read_strings("class");
    if (classes.size() != names.size())
      throw InputError(path, "/materials/class has " + count_text(classes.size()) + " entries for " +
                                 count_text(names.size()) + " materials");
    for (std::size_t m = 0; m < names.size(); ++m) t.materials[m].class_name = classes[m];
  }
  for (const auto& c : kMaterialColumns) {
    if (c.optional && !g_mat.has(c.name)) continue;
    const auto column = g_mat.read_doubles(c.name, {u64(names.size())});
    for (std::size_t m = 0; m < names.size(); ++m) t.materials[m].*(c.field) = column[m];
  }

  const h5::Group g_rough = root.open_group("roughness");
  t.roughness.sigma = g_rough.attr_double("sigma");
  t.roughness.seed = static_cast<std::uint64_t>(g_rough.attr_int("seed"));
  info.roughness_index = std::nullopt;
  if (g_rough.has_attr("roughness_index")) info.roughness_index = g_rough.attr_double("roughness_index");

  if (const std::string problem = terrain_problem(t); !problem.empty())
    throw InputError(path, "corrupt terrain file: " + problem);
  if (t.grid) {
    // The stored TRN must be the one the grid implies, vertex positions and triangle
    // vertex order included: the engine rebuilds it from /grid, other readers use /trn.
    std::vector<std::array<std::int32_t, 3>> expected;
    try {
      expected = grid_triangles(t);
    } catch (const core::Error& e) {
      throw InputError(path, std::string("corrupt terrain file: ") + e.what());
    }
    const terrain::Surface base = terrain::Surface::realize(t, std::nullopt);
    for (std::size_t v = 0; v < t.mesh.vertices.size(); ++v)
      if (base.vertex(v) != t.mesh.vertices[v])
        throw InputError(path, "/trn/vertices row " + count_text(v) + " is not at its grid position");
    for (std::size_t k = 0; k < n_tri; ++k)
      if (expected[k] != t.mesh.triangles[k])
        throw InputError(path, "/trn/triangles row " + count_text(k) + " does not match the grid and /grid/diagonal");
  }
  return t;
}

namespace {

struct Fnv1a {
  std::uint64_t h = 14695981039346656037ull;
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ p[k]) * 1099511628211ull;
  }
  template <class T>
  void value(const T& v) {
    bytes(&v, sizeof v);
  }
};

}  // namespace

std::string terrain_fingerprint(const terrain::Terrain& t) {
  Fnv1a f;
  for (const auto& v : t.mesh.vertices)
    for (int k = 0; k < 3; ++k) f.value(v[k]);
  for (const auto& tri : t.mesh.triangles) f.bytes(tri.data(), sizeof(std::int32_t) * 3);
  f.bytes(t.material_of_triangle.data(), t.material_of_triangle.size() * sizeof(std::int32_t));
  for (const auto& m : t.materials) {
    f.bytes(m.name.data(), m.name.size());
    for (const auto& c : kMaterialColumns)
      if (!c.optional || m.*(c.field) != Material{}.*(c.field)) f.value(m.*(c.field));
  }
  f.value(t.roughness.sigma);
  f.value(t.roughness.seed);
  for (int k = 0; k < 3; ++k) f.value(t.origin_shift[k]);
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(f.h));
  return text;
}

}  // namespace talus::io
