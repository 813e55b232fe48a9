#include "talus/geometry/polyhedron.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace talus::geometry {
namespace {

Polyhedron box(double a, double b, double c) {
  Polyhedron p;
  for (int k = 0; k < 8; ++k) p.vertices.emplace_back((k & 1) ? a : 0.0, (k & 2) ? b : 0.0, (k & 4) ? c : 0.0);
  p.faces = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  return p;
}

// Closed forms for a box: V = abc, I_xx = V (b² + c²)/12.
TEST(MassProperties, BoxMatchesClosedForm) {
  const double a = 2.0, b = 3.0, c = 0.5;
  const MassProperties m = mass_properties(box(a, b, c));
  const double v = a * b * c;
  EXPECT_NEAR(m.volume, v, 1e-14 * v);
  EXPECT_NEAR((m.centroid - Vec3(a / 2, b / 2, c / 2)).norm(), 0.0, 1e-14);
  EXPECT_NEAR(m.inertia(0, 0), v * (b * b + c * c) / 12, 1e-13);
  EXPECT_NEAR(m.inertia(1, 1), v * (a * a + c * c) / 12, 1e-13);
  EXPECT_NEAR(m.inertia(2, 2), v * (a * a + b * b) / 12, 1e-13);
  EXPECT_NEAR(m.inertia(0, 1), 0.0, 1e-13);
  EXPECT_NEAR(m.surface_area, 2 * (a * b + b * c + a * c), 1e-13);
}

// Rigid motion far from the origin changes nothing but the centroid.
TEST(MassProperties, InvariantUnderRigidMotion) {
  Polyhedron p = box(1.0, 2.0, 3.0);
  const MassProperties ref = mass_properties(p);
  const Mat3 r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 t(5e5, -3e5, 1200.0);  // projected-coordinate magnitudes
  for (Vec3& v : p.vertices) v = r * v + t;
  const MassProperties moved = mass_properties(p);
  EXPECT_NEAR(moved.volume, ref.volume, 1e-9 * ref.volume);
  EXPECT_NEAR((moved.centroid - (r * ref.centroid + t)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((moved.inertia - r * ref.inertia * r.transpose()).norm(), 0.0, 1e-8 * ref.inertia.norm());
}

TEST(Sphericity, CubeIsReferenceValue) {
  // SPEC §3: cube ψ = 0.8060.
  EXPECT_NEAR(sphericity(1.0, 6.0), 0.8060, 5e-5);
}

}  // namespace
}  // namespace talus::geometry
