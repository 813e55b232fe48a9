#include "talus/io/terrain_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>

#include "talus/core/error.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/xdmf.hpp"
#include "talus/terrain/build.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

namespace fs = std::filesystem;
using terrain::Terrain;

std::string temp_file(const std::string& name) {
  return talus::testing::temp_path("terrain_file_test", name);
}

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

Provenance sample_provenance() {
  Provenance p;
  p.tool = "terrain-gen";
  p.tool_version = "0.1.0";
  p.settings_yaml = "seed: 7\n";
  p.command_line = "terrain-gen -o t.h5";
  p.seed = 7;
  p.inputs = "dem.asc\n";
  return p;
}

// A 5 × 4 grid with a ridge, alternating diagonals, two materials and roughness.
Terrain grid_terrain() {
  terrain::DemGrid dem;
  dem.spec = {10.0, 20.0, 2.0, 1.5, 5, 4};
  for (std::int32_t j = 0; j < 4; ++j)
    for (std::int32_t i = 0; i < 5; ++i) dem.z.push_back(30.0 - 1.25 * i + 0.1 * (j % 2));
  Terrain t = terrain::build_grid_terrain(dem, terrain::Diagonal::alternating, 42, "test");
  t.name = "ridge";
  terrain::Material scree;
  scree.name = "scree";
  scree.class_name = "loose_scree";  // the class it started from (parameters then edited)
  scree.restitution_mean = 0.8;
  scree.friction_angle_mean_deg = 25.0;
  scree.lateral_tilt_sd_deg = 3.0;
  t.materials.push_back(scree);
  for (std::size_t k = 0; k < t.material_of_triangle.size(); k += 3) t.material_of_triangle[k] = 1;
  t.roughness.sigma = 0.2;
  t.roughness.seed = 0xFEDCBA9876543210ull;  // above 2^63: the stored bit pattern must survive
  t.origin_shift = geometry::Vec3(600000.0, 5100000.0, 0.0);
  return t;
}

// A TIN with a vertical wall: two triangles on the ground, two on the wall.
Terrain tin_terrain() {
  Terrain t;
  t.name = "quarry";
  t.mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {1, 0, 2}, {1, 1, 2}};
  t.mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}};
  t.material_of_triangle = {0, 0, 1, 1};
  t.materials.resize(2);
  t.materials[1].name = "wall";
  t.materials[1].restitution_scale = 9.0;
  t.roughness.sigma = 0.05;
  t.roughness.seed = 3;
  return t;
}

void expect_same_terrain(const Terrain& a, const Terrain& b) {
  EXPECT_EQ(a.name, b.name);
  ASSERT_EQ(a.grid.has_value(), b.grid.has_value());
  if (a.grid) {
    EXPECT_EQ(a.grid->x0, b.grid->x0);
    EXPECT_EQ(a.grid->y0, b.grid->y0);
    EXPECT_EQ(a.grid->dx, b.grid->dx);
    EXPECT_EQ(a.grid->dy, b.grid->dy);
    EXPECT_EQ(a.grid->nx, b.grid->nx);
    EXPECT_EQ(a.grid->ny, b.grid->ny);
  }
  EXPECT_EQ(a.cell_diagonal, b.cell_diagonal);
  EXPECT_EQ(a.mesh.vertices, b.mesh.vertices);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  EXPECT_EQ(a.material_of_triangle, b.material_of_triangle);
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (std::size_t m = 0; m < a.materials.size(); ++m) {
    const auto &p = a.materials[m], &q = b.materials[m];
    EXPECT_EQ(p.name, q.name);
    EXPECT_EQ(p.restitution_mean, q.restitution_mean);
    EXPECT_EQ(p.restitution_sd, q.restitution_sd);
    EXPECT_EQ(p.restitution_scale, q.restitution_scale);
    EXPECT_EQ(p.friction_angle_mean_deg, q.friction_angle_mean_deg);
    EXPECT_EQ(p.friction_coefficient_sd, q.friction_coefficient_sd);
    EXPECT_EQ(p.lateral_tilt_sd_deg, q.lateral_tilt_sd_deg);
    EXPECT_EQ(p.class_name, q.class_name);
  }
  EXPECT_EQ(a.roughness.sigma, b.roughness.sigma);
  EXPECT_EQ(a.roughness.seed, b.roughness.seed);
  EXPECT_EQ(a.origin_shift, b.origin_shift);
}

TEST(TerrainFile, GridRoundTripsExactly) {
  const Terrain t = grid_terrain();
  const std::string path = temp_file("grid.h5");
  write_terrain_file(path, t, sample_provenance(), 0.25);
  TerrainFileInfo info;
  const Terrain back = read_terrain_file(path, info);
  expect_same_terrain(t, back);
  EXPECT_EQ(info.roughness_index, 0.25);
  EXPECT_EQ(info.version.major, kTerrainSchema.major);
  EXPECT_EQ(info.provenance.settings_yaml, "seed: 7\n");
  EXPECT_EQ(info.provenance.seed, 7u);

  // Any HDF5 reader sees the TRN and the grid without Talus logic.
  const h5::File f = h5::File::open(path);
  const h5::Group root = f.root();
  EXPECT_EQ(root.attr_string("kind"), "grid");
  EXPECT_EQ(root.open_group("trn").shape("vertices"), (h5::Shape{20, 3}));
  EXPECT_EQ(root.open_group("trn").shape("triangles"), (h5::Shape{24, 3}));
  EXPECT_EQ(root.open_group("trn").dataset_attr_string("vertices", "unit"), "m");
  EXPECT_EQ(root.open_group("grid").shape("z"), (h5::Shape{4, 5}));
  EXPECT_EQ(root.open_group("grid").shape("diagonal"), (h5::Shape{3, 4}));
  EXPECT_EQ(root.open_group("materials").dataset_attr_string("restitution_scale", "unit"), "m/s");
  EXPECT_EQ(root.open_group("roughness").attr_double("sigma"), 0.2);
  fs::remove(path);
}

TEST(TerrainFile, TinRoundTripsWithoutRoughnessIndex) {
  const Terrain t = tin_terrain();
  const std::string path = temp_file("tin.h5");
  write_terrain_file(path, t, sample_provenance());
  TerrainFileInfo info;
  expect_same_terrain(t, read_terrain_file(path, info));
  EXPECT_FALSE(info.roughness_index.has_value());
  EXPECT_FALSE(h5::File::open(path).root().has("grid"));
  EXPECT_FALSE(h5::File::open(path).root().has_attr("crs_wkt"));  // none known: none written
  EXPECT_EQ(read_terrain_file(path).crs_wkt, "");
  fs::remove(path);
}

TEST(TerrainFile, CrsRoundTripsAsAnAttribute) {
  Terrain t = grid_terrain();
  t.crs_wkt = "PROJCRS[\"WGS 84 / UTM zone 32N\",ID[\"EPSG\",32632]]";  // stored as given
  const std::string path = temp_file("crs.h5");
  write_terrain_file(path, t, sample_provenance());
  EXPECT_EQ(read_terrain_file(path).crs_wkt, t.crs_wkt);
  EXPECT_EQ(h5::File::open(path).root().attr_string("crs_wkt"), t.crs_wkt);
  // The CRS does not change the terrain's geometry, nor its fingerprint.
  Terrain bare = t;
  bare.crs_wkt.clear();
  EXPECT_EQ(terrain_fingerprint(t), terrain_fingerprint(bare));
  fs::remove(path);
}

TEST(TerrainFile, SameInputGivesIdenticalBytes) {
  const std::string a = temp_file("same_a.h5"), b = temp_file("same_b.h5");
  write_terrain_file(a, grid_terrain(), sample_provenance(), 0.25);
  write_terrain_file(b, grid_terrain(), sample_provenance(), 0.25);
  EXPECT_FALSE(bytes_of(a).empty());
  EXPECT_EQ(bytes_of(a), bytes_of(b));
  fs::remove(a);
  fs::remove(b);
}

TEST(TerrainFile, WriterRefusesInconsistentTerrainAndLeavesNothing) {
  Terrain t = tin_terrain();
  t.material_of_triangle[2] = 5;
  const std::string path = temp_file("bad_write.h5");
  EXPECT_THROW(write_terrain_file(path, t, sample_provenance()), core::RuntimeError);
  EXPECT_FALSE(fs::exists(path));
  const std::string nodir = (fs::temp_directory_path() / "talus_no_such_dir" / "t.h5").string();
  EXPECT_THROW(write_terrain_file(nodir, tin_terrain(), sample_provenance()), core::RuntimeError);
}

// The layout written by hand (docs/formats.md, "Terrain file"), with one change applied
// by `mutate` before writing, to check that the reader catches each kind of corruption.
struct Layout {
  std::string kind = "terrain";
  std::string schema = "1.0";
  std::string terrain_kind = "grid";
  Terrain t = grid_terrain();
  std::vector<double> grid_z;
  bool with_materials = true;
  std::uint64_t triangle_columns = 3;
};

void write_layout(const std::string& path, const Layout& l) {
  const h5::File f = h5::File::create(path);
  const h5::Group root = f.root();
  write_header(root, l.kind, kTerrainSchema, sample_provenance());
  root.set_attr("schema_version", l.schema);
  root.set_attr("name", l.t.name);
  root.set_attr("kind", l.terrain_kind);
  root.write("origin_shift", l.t.origin_shift.data(), {3}, "m");
  const h5::Group trn = root.create_group("trn");
  std::vector<double> v;
  for (const auto& p : l.t.mesh.vertices) v.insert(v.end(), {p.x(), p.y(), p.z()});
  trn.write("vertices", v.data(), {l.t.mesh.vertices.size(), 3});
  std::vector<std::int32_t> tri;
  for (const auto& k : l.t.mesh.triangles) {
    tri.insert(tri.end(), k.begin(), k.end());
    if (l.triangle_columns == 4) tri.push_back(0);
  }
  trn.write("triangles", tri.data(), {l.t.mesh.triangles.size(), l.triangle_columns});
  trn.write("material", l.t.material_of_triangle.data(), {l.t.material_of_triangle.size()});
  if (l.t.grid) {
    const auto& s = *l.t.grid;
    const h5::Group g = root.create_group("grid");
    g.set_attr("x0", s.x0);
    g.set_attr("y0", s.y0);
    g.set_attr("dx", s.dx);
    g.set_attr("dy", s.dy);
    g.set_attr("nx", std::int64_t{s.nx});
    g.set_attr("ny", std::int64_t{s.ny});
    std::vector<double> z = l.grid_z;
    if (z.empty())
      for (const auto& p : l.t.mesh.vertices) z.push_back(p.z());
    g.write("z", z.data(), {std::uint64_t(s.ny), std::uint64_t(s.nx)});
    g.write("diagonal", l.t.cell_diagonal.data(), {std::uint64_t(s.ny - 1), std::uint64_t(s.nx - 1)});
  }
  if (l.with_materials) {
    const h5::Group m = root.create_group("materials");
    std::vector<std::string> names;
    std::vector<double> rm, rs, k, fa, fs_, lt;
    for (const auto& mat : l.t.materials) {
      names.push_back(mat.name);
      rm.push_back(mat.restitution_mean);
      rs.push_back(mat.restitution_sd);
      k.push_back(mat.restitution_scale);
      fa.push_back(mat.friction_angle_mean_deg);
      fs_.push_back(mat.friction_coefficient_sd);
      lt.push_back(mat.lateral_tilt_sd_deg);
    }
    m.write_strings("name", names);
    m.write("restitution_mean", rm.data(), {rm.size()});
    m.write("restitution_sd", rs.data(), {rs.size()});
    m.write("restitution_scale", k.data(), {k.size()});
    m.write("friction_angle_mean_deg", fa.data(), {fa.size()});
    m.write("friction_coefficient_sd", fs_.data(), {fs_.size()});
    m.write("lateral_tilt_sd_deg", lt.data(), {lt.size()});
  }
  const h5::Group r = root.create_group("roughness");
  r.set_attr("sigma", l.t.roughness.sigma);
  r.set_attr("seed", static_cast<std::int64_t>(l.t.roughness.seed));
}

std::string read_error(const std::function<void(Layout&)>& mutate) {
  Layout l;
  mutate(l);
  const std::string path = temp_file("corrupt.h5");
  write_layout(path, l);
  std::string message = "no error";
  try {
    read_terrain_file(path);
  } catch (const core::InputError& e) {
    message = e.what();
  }
  fs::remove(path);
  // Strip the file name for comparison; check it was there.
  if (message.rfind(path + ": ", 0) != 0) return "message does not start with the file: " + message;
  return message.substr(path.size() + 2);
}

TEST(TerrainFile, HandWrittenLayoutReads) {
  // The hand-written layout is the documented one: unmodified, it reads back.
  EXPECT_EQ(read_error([](Layout&) {}), "message does not start with the file: no error");
}

TEST(TerrainFile, CorruptFilesAreOneLineInputErrors) {
  EXPECT_EQ(read_error([](Layout& l) { l.kind = "block"; }), "is a Talus block file, expected a terrain file");
  EXPECT_EQ(read_error([](Layout& l) { l.schema = "2.0"; }),
            "terrain schema version 2.0 is not supported (this build reads 1.x)");
  EXPECT_EQ(read_error([](Layout& l) { l.terrain_kind = "voxels"; }),
            "unknown terrain kind 'voxels' (expected grid or tin)");
  EXPECT_EQ(read_error([](Layout& l) { l.with_materials = false; }), "missing group /materials");
  EXPECT_EQ(read_error([](Layout& l) { l.triangle_columns = 4; }),
            "/trn/triangles has shape [24 x 4], expected [* x 3]");
  EXPECT_EQ(read_error([](Layout& l) { l.t.material_of_triangle[7] = 2; }),
            "corrupt terrain file: triangle 7 has material id 2 out of range [0, 2)");
  EXPECT_EQ(read_error([](Layout& l) { l.t.mesh.vertices[3].z() = std::nan(""); }),
            "corrupt terrain file: vertex 3 is not finite");
  EXPECT_EQ(read_error([](Layout& l) { l.t.mesh.vertices[3].z() = 1e308; }),
            "corrupt terrain file: vertex 3 lies beyond 1e9 m");
  EXPECT_EQ(read_error([](Layout& l) { l.t.materials[1].restitution_scale = 0.0; }),
            "corrupt terrain file: material 'scree': restitution_scale = 0 is outside (0, 1000] m/s");
  EXPECT_EQ(read_error([](Layout& l) { l.t.materials[1].restitution_mean = 5.0; }),
            "corrupt terrain file: material 'scree': restitution_mean = 5 is outside [0, 1]");
  EXPECT_EQ(read_error([](Layout& l) { l.t.materials[1].friction_angle_mean_deg = 100.0; }),
            "corrupt terrain file: material 'scree': friction_angle_mean_deg = 100 is outside [0, 90) deg");
  EXPECT_EQ(read_error([](Layout& l) { l.t.roughness.sigma = -1.0; }),
            "corrupt terrain file: roughness sigma = -1 is outside [0, 100] m");
  EXPECT_EQ(read_error([](Layout& l) { l.t.roughness.sigma = 1e300; }),
            "corrupt terrain file: roughness sigma = 1e+300 is outside [0, 100] m");
  EXPECT_EQ(read_error([](Layout& l) {
              for (const auto& p : l.t.mesh.vertices) l.grid_z.push_back(p.z());
              l.grid_z[6] += 1.0;
            }),
            "/grid/z differs from /trn/vertices at point 6");
  EXPECT_EQ(read_error([](Layout& l) { l.t.cell_diagonal[2] ^= 1; }),
            "/trn/triangles row 4 does not match the grid and /grid/diagonal");
  EXPECT_EQ(read_error([](Layout& l) { l.t.mesh.vertices[1].x() += 0.5; }),
            "/trn/vertices row 1 is not at its grid position");
  EXPECT_EQ(read_error([](Layout& l) { l.t.mesh.triangles.pop_back(); l.t.material_of_triangle.pop_back(); }),
            "/trn/triangles has 23 rows for a grid of 12 cells (expected two per cell)");
  EXPECT_EQ(read_error([](Layout& l) {
              l.terrain_kind = "tin";
              l.t = tin_terrain();
              l.t.mesh.triangles[1][2] = 6;
            }),
            "corrupt terrain file: triangle 1 has vertex index 6 out of range [0, 6)");
}

TEST(TerrainFile, NonTerrainFilesAreInputErrors) {
  const std::string path = temp_file("not_hdf5.h5");
  std::ofstream(path) << "plain text";
  EXPECT_THROW(read_terrain_file(path), core::InputError);
  fs::remove(path);
  EXPECT_THROW(read_terrain_file(temp_file("missing.h5")), core::InputError);
}

TEST(Xdmf, DescribesTheTrnDatasets) {
  EXPECT_EQ(xdmf_sidecar_path("out/slope.h5"), "out/slope.xmf");
  const std::string text = terrain_xdmf("slope.h5", 651, 1200);
  EXPECT_NE(text.find("<Topology TopologyType=\"Triangle\" NumberOfElements=\"1200\">"), std::string::npos);
  EXPECT_NE(text.find("Dimensions=\"1200 3\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">slope.h5:/trn/triangles<"),
            std::string::npos);
  EXPECT_NE(text.find("<Geometry GeometryType=\"XYZ\">"), std::string::npos);
  EXPECT_NE(text.find("Dimensions=\"651 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">slope.h5:/trn/vertices<"),
            std::string::npos);
  EXPECT_NE(text.find("<Attribute Name=\"material\" AttributeType=\"Scalar\" Center=\"Cell\">"), std::string::npos);
  EXPECT_NE(text.find(">slope.h5:/trn/material<"), std::string::npos);
  EXPECT_NE(terrain_xdmf("a&b.h5", 1, 1).find(">a&amp;b.h5:/trn/vertices<"), std::string::npos);
}

TEST(Xdmf, SidecarNamesTheFileRelatively) {
  const std::string h5 = temp_file("side.h5");
  const std::string xmf = xdmf_sidecar_path(h5);
  write_terrain_xdmf(xmf, h5, 3, 1);
  const std::string text = bytes_of(xmf);
  EXPECT_NE(text.find(">" + fs::path(h5).filename().string() + ":/trn/vertices<"), std::string::npos);
  EXPECT_EQ(text.find(fs::temp_directory_path().string()), std::string::npos);
  fs::remove(xmf);
}

}  // namespace
}  // namespace talus::io
