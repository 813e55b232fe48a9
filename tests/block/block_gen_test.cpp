// End-to-end tests of the block-gen executable: run the built binary, check the exit
// code, the one-line message and the output files.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "talus/block/solids.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/hdf5.hpp"
#include "../tools/tool_run.hpp"
#include "test_support.hpp"

namespace talus::block {
namespace {

namespace fs = std::filesystem;
using test::read_text;
using test::write_text;

const std::string kSample = std::string(TALUS_SOURCE_DIR) + "/samples/blocks/platonic.yaml";

using Outcome = talus::testing::ToolOutcome;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class BlockGen : public test::ScratchTest {
 protected:
  Outcome run(const std::vector<std::string>& args) const {
    return talus::testing::run_tool(talus::testing::tool_path("block-gen"), args, dir_);
  }
  // A triangulated solid written as OBJ in the scratch directory, moved off the origin.
  std::string solid_obj(const std::string& name, SolidKind kind, bool inside_out = false, bool open = false) const {
    SolidSpec spec;
    spec.kind = kind;
    geometry::TriangleMesh m =
        geometry::triangulate(test::moved(make_solid(spec, "t"), test::arbitrary_rotation(), geometry::Vec3(10, 20, 30)));
    if (inside_out)
      for (auto& t : m.triangles) std::swap(t[1], t[2]);
    if (open) m.triangles.pop_back();
    write_text(path(name), test::obj_text(m));
    return name;
  }
  bool exists(const std::string& name) const { return fs::exists(dir_ / name); }
};

TEST_F(BlockGen, PlatonicSampleMakesTheFourReferenceBlocks) {
  const Outcome r = run({"-c", kSample, "-o", "platonic.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto blocks = io::read_block_file(path("platonic.h5"));
  ASSERT_EQ(blocks.size(), 4u);
  const char* names[] = {"R1", "R2", "R3", "R4"};
  const double psi[] = {0.6711, 0.8060, 0.8456, 0.9105};  // SPEC §3, 4 digits
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(blocks[i].name, names[i]);
    EXPECT_NEAR(blocks[i].volume_exact, 1.0, 1e-12);
    EXPECT_NEAR(blocks[i].sphericity, psi[i], 0.5e-4);
    EXPECT_NEAR(blocks[i].mass, 2800.0, 1e-9);
  }
  EXPECT_TRUE(exists("platonic.xmf"));
  EXPECT_TRUE(contains(read_text(path("platonic.xmf")), "platonic.h5:/blocks/block_0003/vertices"));
  // Provenance: the effective settings can regenerate the file.
  const io::h5::File f = io::h5::File::open(path("platonic.h5"));
  const io::Provenance p = io::read_provenance(f.root());
  EXPECT_EQ(p.tool, "block-gen");
  EXPECT_TRUE(contains(p.settings_yaml, "dodecahedron"));
  write_text(path("again.yaml"), p.settings_yaml);
  ASSERT_EQ(run({"-c", "again.yaml", "-o", "again.h5"}).code, 0);
  const auto again = io::read_block_file(path("again.h5"));
  ASSERT_EQ(again.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(again[i].polyhedron.vertices, blocks[i].polyhedron.vertices);

  const Outcome info = run({"info", "platonic.h5"});
  ASSERT_EQ(info.code, 0) << info.err;
  EXPECT_TRUE(contains(info.out, "platonic.h5: block library of 4 block(s)"));
  EXPECT_TRUE(contains(info.out, "block 'R4' (from dodecahedron)"));
  EXPECT_TRUE(contains(info.out, "sphericity         0.910453"));
  EXPECT_TRUE(contains(info.out, "sampling share     0.25"));
  EXPECT_EQ(run({"--info", "platonic.h5"}).out, info.out);
}

TEST_F(BlockGen, SameSettingsGiveIdenticalFiles) {
  write_text(path("rocks.yaml"),
             "blocks:\n  - {solid: rock, volume: 0.5, seed: 9, elongation: 0.5}\n"
             "  - {solid: ellipsoid, dimensions: [1, 1, 1], resolution: 6, roughness: 0.1, seed: 4}\n");
  // Same command line (it is part of the provenance), so the whole file must repeat.
  ASSERT_EQ(run({"-c", "rocks.yaml", "-o", "a.h5"}).code, 0);
  fs::rename(path("a.h5"), path("first.h5"));
  ASSERT_EQ(run({"-c", "rocks.yaml", "-o", "a.h5"}).code, 0);
  EXPECT_TRUE(read_text(path("a.h5")) == read_text(path("first.h5")));
  const auto blocks = io::read_block_file(path("a.h5"));
  EXPECT_EQ(blocks[0].name, "rock");
  EXPECT_NEAR(blocks[0].dimensions[1] / blocks[0].dimensions[0], 0.5, 1e-6);
}

TEST_F(BlockGen, MeshOnTheCommandLineInAnyPose) {
  solid_obj("cube.obj", SolidKind::cube);
  const Outcome r = run({"cube.obj", "-o", "cube.h5", "--export-mesh", "cube_out.obj"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto blocks = io::read_block_file(path("cube.h5"));
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].name, "cube");
  EXPECT_EQ(blocks[0].polyhedron.faces.size(), 6u);
  EXPECT_NEAR(blocks[0].volume_exact, 1.0, 1e-12);
  EXPECT_NEAR((blocks[0].centroid - geometry::Vec3(10, 20, 30)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(exists("cube_out.obj"));
  EXPECT_TRUE(contains(read_text(path("cube_out.obj")), "f "));
  EXPECT_FALSE(contains(r.err, "inputs.scale")) << r.err;

  // The same cube drawn in centimetres, read as metres: built, and said to be too large.
  const Outcome cm = run({"cube.obj", "--set", "inputs.scale=50", "-o", "cm.h5"});
  ASSERT_EQ(cm.code, 0) << cm.err;
  EXPECT_TRUE(contains(cm.err, "block 'cube' has a volume of 125000 m^3, more than rockfall blocks have (1e4 m^3): "
                               "if the mesh is in centimetres or millimetres, set inputs.scale to 0.01 or 0.001"))
      << cm.err;
}

TEST_F(BlockGen, InsideOutMeshIsRefusedOrRepairedWhenAsked) {
  solid_obj("rock.obj", SolidKind::icosahedron, true);
  Outcome r = run({"rock.obj", "-o", "rock.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_TRUE(contains(r.err, "block-gen: error: rock.obj: inside-out: faces are oriented inward")) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1);
  EXPECT_FALSE(exists("rock.h5"));
  EXPECT_FALSE(exists("rock.xmf"));

  r = run({"rock.obj", "-o", "rock.h5", "--set", "inputs.repair.orient=true"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "rock.obj: repaired: turned inside-out surface outward")) << r.err;
  const Outcome info = run({"info", "rock.h5"});
  EXPECT_TRUE(contains(info.out, "note: repaired: turned inside-out surface outward")) << info.out;
}

TEST_F(BlockGen, OpenMeshIsRefusedOrFilledWhenAsked) {
  solid_obj("scan.obj", SolidKind::octahedron, false, true);
  write_text(path("fill.yaml"), "blocks:\n  - mesh: scan.obj\n    input:\n      repair: {fill_holes: true}\n");
  Outcome r = run({"scan.obj", "-o", "scan.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_TRUE(contains(r.err, "block-gen: error: scan.obj: open surface: 3 boundary edge(s) in 1 hole(s)")) << r.err;
  r = run({"-c", "fill.yaml", "-o", "scan.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "repaired: filled 1 hole(s)")) << r.err;
  EXPECT_NEAR(io::read_block_file(path("scan.h5"))[0].volume_exact, 1.0, 1e-12);
}

TEST_F(BlockGen, CloudsEmptyFilesAndBadSettingsAreClearErrors) {
  write_text(path("flat.xyz"), "0 0 0\n1 0 0\n0 1 0\n1 1 0\n0.5 0.5 0\n");
  Outcome r = run({"flat.xyz", "-o", "x.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_EQ(r.err, "block-gen: error: flat.xyz: coplanar point cloud: all points lie in one plane (no volume)\n");

  write_text(path("empty.obj"), "");
  r = run({"empty.obj", "-o", "x.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_EQ(r.err, "block-gen: error: empty.obj: empty mesh file\n");

  write_text(path("typo.yaml"), "blocks:\n  - solid: cube\n    volumen: 2\n");
  r = run({"-c", "typo.yaml", "-o", "x.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_TRUE(contains(r.err, "unknown key 'blocks[0].volumen' (did you mean 'blocks[0].volume'?)")) << r.err;

  write_text(path("two.yaml"), "blocks:\n  - {solid: cube}\n  - {solid: cube}\n");
  r = run({"-c", "two.yaml", "-o", "x.h5"});
  EXPECT_EQ(r.code, 3);
  // Named by the line of the second block (its name is the solid's).
  EXPECT_EQ(r.err, "block-gen: error: two.yaml:3: duplicate block name 'cube' (set 'name' to tell them apart)\n");

  write_text(path("both.yaml"), "blocks:\n  - {solid: cube, mesh: a.obj}\n");
  r = run({"-c", "both.yaml", "-o", "x.h5"});
  EXPECT_EQ(r.code, 3);
  EXPECT_EQ(r.err, "block-gen: error: both.yaml:2: blocks[0]: give exactly one of solid, mesh or cloud (2 given)\n");

  r = run({"-c", kSample});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "block-gen: error: no output file given (-o FILE)\n");
  r = run({"-o", "x.h5"});
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(exists("x.h5"));
}

TEST_F(BlockGen, CloudHullAndSimplificationAreReported) {
  // A cloud: the corners of a 2×1×0.5 box and interior points.
  write_text(path("box.xyz"), "0 0 0\n2 0 0\n0 1 0\n2 1 0\n0 0 0.5\n2 0 0.5\n0 1 0.5\n2 1 0.5\n1 0.5 0.25\n");
  write_text(path("lod.yaml"),
             "blocks:\n"
             "  - {cloud: box.xyz, weight: 2}\n"
             "  - name: scan\n    solid: ellipsoid\n    dimensions: [1, 1, 1]\n    resolution: 6\n    roughness: 0.1\n"
             "    volume: 1\n    input: {simplify: {mode: faces, target_faces: 100}}\n");
  const Outcome r = run({"-c", "lod.yaml", "-o", "lod.h5", "-v"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "scan: simplified 720 -> ")) << r.err;
  const auto blocks = io::read_block_file(path("lod.h5"));
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_EQ(blocks[0].name, "box");
  EXPECT_EQ(blocks[0].polyhedron.faces.size(), 6u);
  EXPECT_EQ(blocks[0].volume_rational, "1");
  EXPECT_EQ(blocks[0].weight, 2.0);
  EXPECT_LE(blocks[1].polyhedron.faces.size(), 100u);
  ASSERT_FALSE(blocks[1].notes.empty());
  EXPECT_TRUE(contains(blocks[1].notes.back(), "volume")) << blocks[1].notes.back();
}

// The documented examples stay valid: every key is known, and those that need no
// external file run.
TEST_F(BlockGen, DocumentedConfigsAreValid) {
  const std::string dir = std::string(TALUS_SOURCE_DIR) + "/configs/blocks/";
  for (const char* name : {"box.yaml", "rock.yaml", "scan-simplified.yaml", "cloud-hull.yaml"}) {
    const Outcome r = run({"-c", dir + name, "--print-config"});
    EXPECT_EQ(r.code, 0) << name << ": " << r.err;
  }
  Outcome r = run({"-c", dir + "box.yaml", "-o", "box.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(io::read_block_file(path("box.h5"))[0].volume_exact, 1.0, 1e-15);
  r = run({"-c", dir + "rock.yaml", "-o", "rocks.h5", "--export-mesh", "rock.ply"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(io::read_block_file(path("rocks.h5")).size(), 4u);
  // One mesh per block, and each reads back as the same solid.
  for (const char* name : {"equant", "platy", "elongated", "rough"}) EXPECT_TRUE(exists(std::string("rock_") + name + ".ply"));
  r = run({"rock_platy.ply", "-o", "platy.h5"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(io::read_block_file(path("platy.h5"))[0].volume_exact, 1.0, 1e-12);
}

}  // namespace
}  // namespace talus::block
