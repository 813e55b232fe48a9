// Properties of blocks against closed forms, the exact path against the double path, and
// invariance under rigid motions of the input.
#include <gtest/gtest.h>

#include <cmath>

#include "talus/block/block.hpp"
#include "talus/block/mesh_check.hpp"
#include "talus/block/solids.hpp"
#include "talus/core/error.hpp"
#include "talus/io/point_cloud.hpp"
#include "test_support.hpp"

namespace talus::block {
namespace {

using geometry::Mat3;
using geometry::Polyhedron;
using geometry::Vec3;

// Closed forms for a Platonic solid of edge a: V = kv a³, A = ka a², and an isotropic
// inertia per unit density J = kj V a².
struct Platonic {
  SolidKind kind;
  std::size_t faces;
  double kv, ka, kj;
  double spec_edge;        // SPEC §3: edge at V = 1 m³ (m), 0 if not listed
  double spec_sphericity;  // SPEC §3, 4 digits, 0 if not listed
};

const double r5 = std::sqrt(5.0);
const Platonic kPlatonic[] = {
    {SolidKind::tetrahedron, 4, 1.0 / (6.0 * std::sqrt(2.0)), std::sqrt(3.0), 1.0 / 20.0, 2.03965, 0.6711},
    {SolidKind::cube, 6, 1.0, 6.0, 1.0 / 6.0, 1.0, 0.8060},
    {SolidKind::octahedron, 8, std::sqrt(2.0) / 3.0, 2.0 * std::sqrt(3.0), 1.0 / 10.0, 1.28490, 0.8456},
    {SolidKind::dodecahedron, 12, (15.0 + 7.0 * r5) / 4.0, 3.0 * std::sqrt(25.0 + 10.0 * r5), (95.0 + 39.0 * r5) / 300.0,
     0.50722, 0.9105},
    {SolidKind::icosahedron, 20, 5.0 * (3.0 + r5) / 12.0, 5.0 * std::sqrt(3.0), (3.0 + r5) / 20.0, 0.0, 0.0},
};

const double kPi = 3.14159265358979323846;

// Round-off of a few hundred operations on O(1) numbers stays far below 1e-10; the
// issue asks for 1e-10 relative.
constexpr double kRel = 1e-10;

void expect_platonic(const Block& b, const Platonic& s, double volume, const std::string& what) {
  SCOPED_TRACE(what + " " + std::string(solid_name(s.kind)));
  const double a = std::cbrt(volume / s.kv);
  EXPECT_EQ(b.polyhedron.faces.size(), s.faces);
  EXPECT_NEAR(b.volume_exact, volume, kRel * volume);
  EXPECT_NEAR(b.volume, volume, kRel * volume);
  EXPECT_NEAR(b.surface_area, s.ka * a * a, kRel * s.ka * a * a);
  const double j = s.kj * volume * a * a;
  EXPECT_NEAR((b.inertia_per_density - j * Mat3::Identity()).norm(), 0.0, kRel * j);
  EXPECT_NEAR((b.inertia - b.density * j * Mat3::Identity()).norm(), 0.0, kRel * b.density * j);
  const double psi = std::cbrt(kPi) * std::pow(6.0 * volume, 2.0 / 3.0) / (s.ka * a * a);
  EXPECT_NEAR(b.sphericity, psi, kRel * psi);
  EXPECT_NEAR(b.mass, b.density * volume, kRel * b.density * volume);
  // The stored polyhedron is in the centroid frame, to the round-off of subtracting the
  // input-frame centroid from each vertex.
  EXPECT_NEAR(geometry::mass_properties(b.polyhedron).centroid.norm(), 0.0, 1e-14 * (a + b.centroid.norm()));
}

TEST(Platonic, NamedSolidsMatchClosedFormsAndSpec) {
  for (const Platonic& s : kPlatonic) {
    SolidSpec spec;
    spec.kind = s.kind;
    spec.volume = 1.0;
    const Block b = make_block("b", make_solid(spec, "test"), 2800.0, "test");
    expect_platonic(b, s, 1.0, "named");
    // SPEC §3 values are given to 4 (sphericity) and 5-6 (edge) digits.
    if (s.spec_sphericity > 0.0) {
      EXPECT_NEAR(b.sphericity, s.spec_sphericity, 0.5e-4);
    }
    if (s.spec_edge > 0.0) {
      const auto& f = b.polyhedron.faces[0];
      const double edge = (b.polyhedron.vertices[f[1]] - b.polyhedron.vertices[f[0]]).norm();
      EXPECT_NEAR(edge, s.spec_edge, 0.5e-5);
    }
    // Any volume: properties scale as V, V^(2/3), V^(5/3).
    spec.volume = 3.7;
    expect_platonic(make_block("b", make_solid(spec, "test"), 2800.0, "test"), s, 3.7, "named, 3.7 m^3");
  }
}

// The same solids as triangle meshes in an arbitrary position and orientation, read from
// OBJ files through the whole import path (assimp, welding, validation, face merging).
class PlatonicMeshes : public test::ScratchTest {};

TEST_F(PlatonicMeshes, ArbitraryPoseThroughImportMatchesClosedForms) {
  const Mat3 r = test::arbitrary_rotation();
  const Vec3 t(1234.5, -567.25, 89.0);
  // Every text format read in double precision, one solid each.
  const char* formats[] = {"obj", "off", "ply", "stl", "obj"};
  int which = 0;
  for (const Platonic& s : kPlatonic) {
    SolidSpec spec;
    spec.kind = s.kind;
    spec.volume = 2.0;
    const Polyhedron posed = test::moved(make_solid(spec, "test"), r, t);
    const std::string format = formats[which++];
    const std::string file = path(std::string(solid_name(s.kind)) + "." + format);
    test::write_text(file, test::mesh_text(test::as_triangles(posed), format));
    const CheckedMesh checked = check_mesh(io::import_mesh(file).mesh, RepairOptions{}, file);
    EXPECT_TRUE(checked.repairs.empty());
    const Block b = make_block("b", checked.polyhedron, 2800.0, file);
    expect_platonic(b, s, 2.0, "mesh");
    EXPECT_NEAR((b.centroid - t).norm(), 0.0, 1e-10 * t.norm());
    EXPECT_NEAR((b.translation - t).norm(), 0.0, 1e-10 * t.norm());
  }
}

TEST(Properties, BoxClosedFormAndDimensions) {
  SolidSpec spec;
  spec.kind = SolidKind::box;
  spec.volume = 0.0;
  spec.dimensions = Vec3(0.5, 2.0, 1.25);
  const Block b = make_block("box", make_solid(spec, "test"), 2500.0, "test");
  const double v = 0.5 * 2.0 * 1.25;
  EXPECT_EQ(b.volume_rational, "5/4");  // exact: every coordinate is a short binary fraction
  EXPECT_DOUBLE_EQ(b.volume_exact, v);
  EXPECT_NEAR(b.inertia(0, 0), 2500.0 * v * (4.0 + 1.5625) / 12.0, 1e-12 * b.inertia.norm());
  EXPECT_NEAR(b.dimensions[0], 2.0, 1e-14);
  EXPECT_NEAR(b.dimensions[1], 1.25, 1e-14);
  EXPECT_NEAR(b.dimensions[2], 0.5, 1e-14);
  // Principal moments ascending; axes orthonormal and right-handed.
  EXPECT_LE(b.principal_moments[0], b.principal_moments[1]);
  EXPECT_LE(b.principal_moments[1], b.principal_moments[2]);
  EXPECT_NEAR((b.principal_axes.transpose() * b.principal_axes - Mat3::Identity()).norm(), 0.0, 1e-14);
  EXPECT_NEAR(b.principal_axes.determinant(), 1.0, 1e-14);
}

// A block thinner than 1/1000 of its length is a sheet the contact model cannot hold
// (kMinThicknessRatio): refused with a one-line reason. A 2 cm slab of 1.5 m is a block.
TEST(Properties, SheetsAreRefused) {
  SolidSpec spec;
  spec.kind = SolidKind::box;
  spec.volume = 0.0;
  spec.dimensions = Vec3(6.0, 5.0, 0.0005);
  try {
    make_block("plate", make_solid(spec, "test"), 2700.0, "plate.xyz");
    ADD_FAILURE() << "a 0.5 mm plate of 6 m was accepted";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "plate.xyz: block is a sheet, not a solid: 0.0005 m thick along its thinnest axis, under 1/1000 of "
              "its length of 6 m");
  }
  spec.dimensions = Vec3(1.5, 1.5, 0.02);
  EXPECT_NO_THROW(make_block("slab", make_solid(spec, "test"), 2700.0, "slab"));
}

TEST(Properties, CubeDimensionsDoNotDependOnOrientation) {
  // Isotropic inertia leaves the principal axes free; the face rule makes L1..L3 the edges.
  SolidSpec spec;
  spec.kind = SolidKind::cube;
  const Polyhedron cube = make_solid(spec, "test");
  const Block a = make_block("a", cube, 2800.0, "test");
  const Block b = make_block("b", test::moved(cube, test::arbitrary_rotation(), Vec3(3, 4, 5)), 2800.0, "test");
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a.dimensions[i], 1.0, 1e-12);
    EXPECT_NEAR(b.dimensions[i], 1.0, 1e-12);
  }
}

// A scanned-like mesh of about 100 000 faces: the exact and the double volume agree.
TEST(Properties, ExactAndDoubleVolumesAgreeOn100kFaces) {
  // 20·71² = 100 820 triangles.
  const Polyhedron scan = test::rough_ellipsoid(Vec3(2.0, 1.3, 0.8), 71, 0.1, 0.0, 7);
  ASSERT_EQ(scan.faces.size(), 100820u);
  const ExactVolume exact = exact_volume(scan);
  const double fast = geometry::mass_properties(scan).volume;
  EXPECT_NEAR(fast, exact.value, 1e-12 * exact.value);
  EXPECT_GT(exact.value, 0.5);
  EXPECT_NE(exact.rational.find('/'), std::string::npos);
}

// Exact arithmetic sees what doubles lose: a huge offset of a tiny tetrahedron.
TEST(Properties, ExactVolumeIsExactFarFromTheOrigin) {
  Polyhedron tet;
  const double big = 0x1p40;
  tet.vertices = {{big, big, big}, {big + 1, big, big}, {big, big + 1, big}, {big, big, big + 1}};
  tet.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  EXPECT_EQ(exact_volume(tet).rational, "1/6");
}

TEST(Properties, InvariantUnderTranslationAndRotation) {
  const Polyhedron rock = test::rough_ellipsoid(Vec3(1.9, 1.1, 0.7), 12, 0.08, 1.5, 3);
  const Block a = make_block("a", rock, 2650.0, "test");
  const Mat3 r = test::arbitrary_rotation();
  const Vec3 t(-350.25, 1200.5, 42.0);
  const Block b = make_block("b", test::moved(rock, r, t), 2650.0, "test");
  auto rel = [](double x, double y) { return std::abs(x - y) / std::abs(x); };
  EXPECT_LT(rel(a.volume_exact, b.volume_exact), kRel);
  EXPECT_LT(rel(a.volume, b.volume), kRel);
  EXPECT_LT(rel(a.surface_area, b.surface_area), kRel);
  EXPECT_LT(rel(a.sphericity, b.sphericity), kRel);
  EXPECT_LT(rel(a.mass, b.mass), kRel);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(rel(a.principal_moments[i], b.principal_moments[i]), kRel);
    EXPECT_LT(rel(a.dimensions[i], b.dimensions[i]), kRel);
  }
  EXPECT_LT((r * a.inertia * r.transpose() - b.inertia).norm() / a.inertia.norm(), kRel);
  EXPECT_LT((r * a.centroid + t - b.centroid).norm(), kRel * t.norm());
  // Each principal axis turns with the input (up to sign).
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(std::abs((r * a.principal_axes.col(i)).dot(b.principal_axes.col(i))), 1.0, 1e-9);
}

TEST(Solids, RockMeetsTargetShapeAndVolume) {
  SolidSpec spec;
  spec.kind = SolidKind::rock;
  spec.volume = 0.8;
  spec.elongation = 0.6;
  spec.flatness = 0.5;
  spec.points = 60;
  spec.seed = 11;
  const Polyhedron rock = make_solid(spec, "test");
  const Block b = make_block("rock", rock, 2800.0, "test");
  EXPECT_NEAR(b.volume_exact, 0.8, 1e-12);
  // The affine correction converges to round-off; 1e-6 leaves room for its last step.
  EXPECT_NEAR(b.dimensions[1] / b.dimensions[0], 0.6, 1e-6);
  EXPECT_NEAR(b.dimensions[2] / b.dimensions[1], 0.5, 1e-6);
  // Same seed, same rock, bit for bit; another seed, another rock.
  EXPECT_EQ(make_solid(spec, "test").vertices, rock.vertices);
  spec.seed = 12;
  EXPECT_FALSE(make_solid(spec, "test").vertices == rock.vertices);
}

TEST(Solids, EllipsoidApproachesTheSmoothVolume) {
  const Block b = make_block("e", test::rough_ellipsoid(Vec3(2.0, 1.0, 1.0), 20, 0.0), 2800.0, "test");
  const double smooth = kPi / 6.0 * 2.0 * 1.0 * 1.0;
  // An inscribed geodesic polyhedron of 8000 faces loses 0.14 % of the volume (measured).
  EXPECT_LT(b.volume_exact, smooth);
  EXPECT_GT(b.volume_exact, smooth * 0.997);
  EXPECT_NEAR(b.dimensions[0], 2.0, 1e-12);
}

TEST(Solids, ParametersOutOfRangeAreClearErrors) {
  SolidSpec spec;
  spec.kind = SolidKind::cube;
  spec.volume = -1.0;
  try {
    make_solid(spec, "cfg.yaml: blocks[0]");
    FAIL() << "negative volume accepted";
  } catch (const core::InputError& e) {
    EXPECT_STREQ(e.what(), "cfg.yaml: blocks[0]: cube needs a positive target volume, got -1 m^3");
  }
  spec.kind = SolidKind::rock;
  spec.volume = 1.0;
  spec.elongation = 1.5;
  EXPECT_THROW(make_solid(spec, "x"), core::InputError);
  spec.kind = SolidKind::ellipsoid;
  spec.roughness = 0.5;
  EXPECT_THROW(make_solid(spec, "x"), core::InputError);
  EXPECT_EQ(parse_solid_kind("dodecahedron"), SolidKind::dodecahedron);
  EXPECT_FALSE(parse_solid_kind("sphere").has_value());
}

}  // namespace
}  // namespace talus::block
