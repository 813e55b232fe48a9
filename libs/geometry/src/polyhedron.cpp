#include "talus/geometry/polyhedron.hpp"

#include <cmath>

namespace talus::geometry {

MassProperties mass_properties(const Polyhedron& poly) {
  // Integrate about a reference point inside the bounding box to limit cancellation
  // for blocks far from the origin, then shift to the centroid.
  Aabb box;
  for (const Vec3& p : poly.vertices) box.add(p);
  const Vec3 ref = box.empty() ? Vec3::Zero() : box.center();

  double volume = 0.0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  double area = 0.0;
  for (const auto& face : poly.faces) {
    if (face.size() < 3) continue;
    const Vec3 p0 = poly.vertices[face[0]] - ref;
    for (std::size_t k = 1; k + 1 < face.size(); ++k) {
      const Vec3 p1 = poly.vertices[face[k]] - ref;
      const Vec3 p2 = poly.vertices[face[k + 1]] - ref;
      const double vt = p0.dot(p1.cross(p2)) / 6.0;
      const Vec3 s = p0 + p1 + p2;
      volume += vt;
      first += vt * s / 4.0;
      second += vt / 20.0 * (p0 * p0.transpose() + p1 * p1.transpose() + p2 * p2.transpose() + s * s.transpose());
      area += 0.5 * (p1 - p0).cross(p2 - p0).norm();
    }
  }
  MassProperties out;
  out.volume = volume;
  out.surface_area = area;
  if (volume == 0.0) return out;
  const Vec3 c = first / volume;
  out.centroid = c + ref;
  out.second_moments = second - volume * c * c.transpose();
  out.inertia = out.second_moments.trace() * Mat3::Identity() - out.second_moments;
  return out;
}

double sphericity(double volume, double surface_area) {
  const double pi = 3.14159265358979323846;
  return std::cbrt(pi) * std::pow(6.0 * volume, 2.0 / 3.0) / surface_area;
}

}  // namespace talus::geometry
