// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "dda_fixtures.hpp"
#include "talus/core/error.hpp"
#include "talus/dda/model.hpp"

namespace talus::dda {
namespace {

using testing::box;
using testing::cube;

std::string build_error(const Settings& s, const geometry::Polyhedron& p) {
  try {
    Model::build(s, p);
  } catch (const core::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(DdaModel, CubeMassAndInertia) {
  const Model m = Model::build(Settings{}, cube(1.0));
  // Closed forms: m = ρa³, J = m a²/6; sums of a few dozen terms, so 1e-12 relative.
  EXPECT_NEAR(m.mass, 2800.0, 1e-9);
  EXPECT_NEAR(m.inertia(0, 0), 2800.0 / 6.0, 1e-9);
  EXPECT_NEAR(m.inertia(0, 1), 0.0, 1e-9);
  EXPECT_NEAR(m.radius, std::sqrt(3.0) / 2.0, 1e-12);
  EXPECT_EQ(m.edges.size(), 12u);
  EXPECT_TRUE(std::all_of(m.edges.begin(), m.edges.end(), [](const BlockEdge& e) { return e.convex; }));
  EXPECT_EQ(m.faces.size(), 6u);
}

// A square pyramid whose base is split into two triangles along a diagonal, the corner
// (1, 0, 0) lowered by `drop` (m): the diagonal is flat when drop = 0, bent outwards
// (convex) when drop < 0 and inwards (reflex) when drop > 0.
geometry::Polyhedron split_pyramid(double drop) {
  geometry::Polyhedron p;
  p.vertices = {Vec3(0, 0, 0), Vec3(1, 0, -drop), Vec3(1, 1, 0), Vec3(0, 1, 0), Vec3(0.5, 0.5, 1)};
  p.faces = {{0, 2, 1}, {0, 3, 2}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  return p;
}

// The block is convex unless it bends inwards at some edge. Between two triangles that is
// decided exactly: a flat diagonal (a flat face split in two) or one bent outwards by
// far less than the convex-edge tolerance (1e-9 of the radius) keeps the block convex,
// though neither is a convex edge; one bent inwards by as little does not. A triangulated
// cube is convex too.
TEST(DdaModel, ConvexUnlessAnEdgeBendsInwardsExactly) {
  for (const double drop : {0.0, -1e-13, 1e-13, -1e-3, 1e-3}) {
    const Model m = Model::build(Settings{}, split_pyramid(drop));
    EXPECT_EQ(m.convex, drop <= 0.0) << drop;
    const auto diagonal = std::find_if(m.edges.begin(), m.edges.end(), [](const BlockEdge& e) {
      return (e.a == 0 && e.b == 2) || (e.a == 2 && e.b == 0);
    });
    ASSERT_NE(diagonal, m.edges.end());
    EXPECT_EQ(diagonal->convex, drop == -1e-3) << drop;
    EXPECT_EQ(std::count_if(m.edges.begin(), m.edges.end(), [](const BlockEdge& e) { return e.convex; }),
              drop == -1e-3 ? 9 : 8)
        << drop;
  }
  geometry::Polyhedron cube12;
  cube12.vertices = cube(1.0).vertices;
  for (const auto& face : cube(1.0).faces) {
    ASSERT_EQ(face.size(), 4u);
    cube12.faces.push_back({face[0], face[1], face[2]});
    cube12.faces.push_back({face[0], face[2], face[3]});
  }
  const Model m = Model::build(Settings{}, cube12);
  EXPECT_TRUE(m.convex);
  EXPECT_EQ(std::count_if(m.edges.begin(), m.edges.end(), [](const BlockEdge& e) { return e.convex; }), 12);
  EXPECT_EQ(m.edges.size(), 18u);
}

// The simplex-integrated 12×12 mass matrix against Gauss quadrature over a box
// (2 points per axis integrate the quadratic integrand exactly).
TEST(DdaModel, MassMatrixMatchesQuadrature) {
  const double ax = 1.3, ay = 0.7, az = 0.9, rho = 2650.0;
  const geometry::MassProperties props = geometry::mass_properties(box(ax, ay, az));
  const Mat12 m = mass_matrix(rho, props.volume, props.second_moments);
  Mat12 q = Mat12::Zero();
  const double g = 1.0 / std::sqrt(3.0);
  const double w = ax * ay * az / 8.0;
  for (int i = 0; i < 8; ++i) {
    const Vec3 r((i & 1 ? g : -g) * ax / 2, (i & 2 ? g : -g) * ay / 2, (i & 4 ? g : -g) * az / 2);
    const auto t = displacement_matrix(r);
    q += rho * w * t.transpose() * t;
  }
  // Round-off of sums of O(10) terms of size ~3e3.
  EXPECT_LT((m - q).cwiseAbs().maxCoeff(), 1e-9);
  // Top-left: diag(m, m, m, J).
  EXPECT_NEAR(m(0, 0), rho * ax * ay * az, 1e-9);
  EXPECT_NEAR(m(3, 3), rho * ax * ay * az * (ay * ay + az * az) / 12.0, 1e-9);
  EXPECT_EQ(m(0, 3), 0.0);
}

TEST(DdaModel, RotationMatrixIsExact) {
  const Vec3 theta(0.3, -0.2, 0.5);
  const Mat3 r = rotation_matrix(theta);
  // Orthogonal and unimodular to round-off; fixes its axis.
  EXPECT_LT((r * r.transpose() - Mat3::Identity()).norm(), 1e-15);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-15);
  EXPECT_LT((r * theta - theta).norm(), 1e-15);
  EXPECT_EQ(rotation_matrix(Vec3::Zero()), Mat3::Identity());
}

TEST(DdaModel, ElasticityMatrix) {
  const Mat6 c = isotropic_elasticity(3e10, 0.2);
  // λ = Eν/((1+ν)(1−2ν)) = 8.333e9, G = E/(2(1+ν)) = 1.25e10.
  EXPECT_NEAR(c(0, 1), 3e10 * 0.2 / (1.2 * 0.6), 1e-3);
  EXPECT_NEAR(c(3, 3), 1.25e10, 1e-3);
  EXPECT_NEAR(c(0, 0), 3e10 * 0.2 / (1.2 * 0.6) + 2.5e10, 1e-3);
}

TEST(DdaModel, BadSettingsAreOneLineErrors) {
  Settings s;
  s.time_step = -1.0;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: time_step = -1: must be in (0, 0.05] s");
  // Upper bounds: a step of 10 s, a penetration limit of 20 diameters, a rest threshold of
  // 1e6 J/kg were accepted and gave nonsense.
  s = Settings{};
  s.time_step = 10.0;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: time_step = 10: must be in (0, 0.05] s");
  s = Settings{};
  s.penetration_limit_ratio = 20.0;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: penetration_limit_ratio = 20: must be in (0, 0.5]");
  s = Settings{};
  s.rest_kinetic_energy = 1e6;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: rest_kinetic_energy = 1000000: must be in [0, 0.5] J/kg");
  // A step below the step control's floor names both fields.
  s = Settings{};
  s.time_step = 1e-9;
  EXPECT_EQ(build_error(s, cube(1.0)),
            "dda settings: time_step = 1e-09 s is below min_time_step = 1e-07 s, the shortest step the step control "
            "may cut to");
  s = Settings{};
  s.dof = "twelve";
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: dof = 'twelve': must be one of rigid6, full12");
  s = Settings{};
  s.dynamic_coefficient = 1.5;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: dynamic_coefficient = 1.5: must be in [0, 1]");
  s = Settings{};
  s.penalty_stiffness = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(build_error(s, cube(1.0)).find("penalty_stiffness"), std::string::npos);
  // The ranges are those the fields declare (Settings::visit), the reader's too.
  s = Settings{};
  s.penalty_stiffness = std::numeric_limits<double>::infinity();
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: penalty_stiffness = inf: must be in [0, inf) N/m");
  s = Settings{};
  s.max_open_close_iterations = 0;
  EXPECT_EQ(build_error(s, cube(1.0)), "dda settings: max_open_close_iterations = 0: must be in [1, 1000]");
}

TEST(DdaModel, BadBlocksAreOneLineErrors) {
  geometry::Polyhedron open = cube(1.0);
  open.faces.pop_back();
  EXPECT_NE(build_error(Settings{}, open).find("block: polyhedron is not closed"), std::string::npos);
  geometry::Polyhedron inside_out = cube(1.0);
  for (auto& f : inside_out.faces) std::reverse(f.begin(), f.end());
  EXPECT_NE(build_error(Settings{}, inside_out).find("not positive"), std::string::npos);
  geometry::Polyhedron bad_index = cube(1.0);
  bad_index.faces[0][0] = 42;
  EXPECT_EQ(build_error(Settings{}, bad_index), "block: face vertex index 42 out of range");
}

}  // namespace
}  // namespace talus::dda

namespace talus::dda {
namespace {

// The default stiffness is relative to the block: every block of a library gets the same
// Ω = √(k/m)·Δt, and an absolute stiffness outside Ω ∈ [3, 300] is refused for that block.
TEST(DdaModel, StiffnessIsRelativeToTheBlock) {
  Settings set;
  for (const double volume : {1e-3, 1.0, 1000.0}) {
    const Model m = Model::build(set, testing::cube(std::cbrt(volume)));
    EXPECT_NEAR(std::sqrt(m.stiffness / m.mass) * set.time_step, set.penalty_omega, 1e-12 * set.penalty_omega)
        << "volume " << volume;
  }
  set.penalty_stiffness = 1e12;  // N/m: Ω = 19 for 1 m³ (2800 kg), 598 for 1e-3 m³
  EXPECT_NO_THROW(Model::build(set, testing::cube(1.0)));
  const std::string error = build_error(set, testing::cube(0.1));
  EXPECT_NE(error.find("outside the well-posed range [3, 300]"), std::string::npos) << error;
  set.penalty_stiffness = 0.0;
  set.penalty_omega = 0.5;
  EXPECT_EQ(build_error(set, testing::cube(1.0)), "dda settings: penalty_omega = 0.5: must be in [3, 300]");
}

// The energy-gain bound of the step control is a fraction; 0 turns the redo off.
TEST(DdaModel, StepEnergyGainBoundIsValidated) {
  Settings set;
  set.max_step_energy_gain = 0.0;
  EXPECT_NO_THROW(Model::build(set, testing::cube(1.0)));
  set.max_step_energy_gain = -0.01;
  EXPECT_EQ(build_error(set, testing::cube(1.0)),
            "dda settings: max_step_energy_gain = -0.01: must be in [0, inf)");
}

// The step control is scaled by the block's thickness as well as its diameter: a needle
// may not move by its own thickness in one step, a cube keeps its diameter.
TEST(DdaModel, StepControlScaleFollowsTheThinnestAxis) {
  const Settings set;
  const Model cube = Model::build(set, testing::cube(1.0));
  EXPECT_NEAR(cube.size, 2.0 * cube.radius, 1e-12);
  geometry::Polyhedron needle = testing::cube(1.0);
  for (Vec3& p : needle.vertices) p = Vec3(5.0 * p.x(), 0.1 * p.y(), 0.1 * p.z());
  const Model m = Model::build(set, needle);
  EXPECT_NEAR(m.size, 0.2, 1e-9);  // twice the 0.1 m thickness
  EXPECT_NEAR(m.max_step_displacement(), set.max_displacement_ratio * 0.2, 1e-12);
}

}  // namespace
}  // namespace talus::dda
