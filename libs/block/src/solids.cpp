#include "talus/block/solids.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include "talus/block/block.hpp"
#include "talus/block/hull.hpp"
#include "talus/core/error.hpp"
#include "talus/core/random.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/geometry/triangle_mesh.hpp"

namespace talus::block {

using geometry::Polyhedron;
using geometry::Vec3;

namespace {

constexpr std::array<std::pair<SolidKind, std::string_view>, 8> kNames{{
    {SolidKind::tetrahedron, "tetrahedron"},
    {SolidKind::cube, "cube"},
    {SolidKind::octahedron, "octahedron"},
    {SolidKind::dodecahedron, "dodecahedron"},
    {SolidKind::icosahedron, "icosahedron"},
    {SolidKind::box, "box"},
    {SolidKind::ellipsoid, "ellipsoid"},
    {SolidKind::rock, "rock"},
}};

const double kPhi = (1.0 + std::sqrt(5.0)) / 2.0;

std::vector<Vec3> platonic_vertices(SolidKind kind) {
  std::vector<Vec3> v;
  switch (kind) {
    case SolidKind::tetrahedron:
      v = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
      break;
    case SolidKind::cube:
      for (int k = 0; k < 8; ++k) v.emplace_back((k & 1) ? 0.5 : -0.5, (k & 2) ? 0.5 : -0.5, (k & 4) ? 0.5 : -0.5);
      break;
    case SolidKind::octahedron:
      for (int i = 0; i < 3; ++i)
        for (double s : {1.0, -1.0}) {
          Vec3 p = Vec3::Zero();
          p[i] = s;
          v.push_back(p);
        }
      break;
    case SolidKind::icosahedron:
      for (double a : {1.0, -1.0})
        for (double b : {kPhi, -kPhi}) {
          v.emplace_back(0, a, b);
          v.emplace_back(a, b, 0);
          v.emplace_back(b, 0, a);
        }
      break;
    case SolidKind::dodecahedron:
      for (int k = 0; k < 8; ++k) v.emplace_back((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1);
      for (double a : {1.0 / kPhi, -1.0 / kPhi})
        for (double b : {kPhi, -kPhi}) {
          v.emplace_back(0, a, b);
          v.emplace_back(a, b, 0);
          v.emplace_back(b, 0, a);
        }
      break;
    default:
      break;
  }
  return v;
}

void scale(Polyhedron& poly, double s) {
  for (Vec3& p : poly.vertices) p *= s;
}

double volume_of(const Polyhedron& poly) { return geometry::mass_properties(poly).volume; }

// Geodesic sphere of frequency n: each icosahedron face split into n² triangles, the
// points pushed onto the unit sphere. Points on corners and edges are created once and
// shared by the faces that meet there.
geometry::TriangleMesh geodesic_sphere(int n) {
  const Polyhedron ico = small_convex_hull(platonic_vertices(SolidKind::icosahedron), 1e-9);
  geometry::TriangleMesh mesh;
  mesh.vertices = ico.vertices;
  for (Vec3& p : mesh.vertices) p.normalize();
  const auto& corner = ico.vertices;
  // Interior points of edge (u, v), u < v: step s = 1 … n−1 from u, created on first use.
  std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> edge_base;
  auto edge_point = [&](std::int32_t u, std::int32_t v, int s) {
    if (u > v) {
      std::swap(u, v);
      s = n - s;
    }
    auto [it, added] = edge_base.try_emplace({u, v}, static_cast<std::int32_t>(mesh.vertices.size()));
    if (added)
      for (int t = 1; t < n; ++t)
        mesh.vertices.push_back((static_cast<double>(n - t) * corner[u] + static_cast<double>(t) * corner[v]).normalized());
    return it->second + s - 1;
  };
  std::vector<std::int32_t> lattice;
  for (const auto& face : ico.faces) {
    const std::int32_t a = face[0], b = face[1], c = face[2];
    // Lattice point (i, j): weights n−i−j, i, j on corners a, b, c.
    auto slot = [n](int i, int j) { return static_cast<std::size_t>(j * (n + 1) - j * (j - 1) / 2 + i); };
    lattice.assign(slot(0, n) + 1, -1);
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i + j <= n; ++i) {
        const int k = n - i - j;
        std::int32_t index;
        if (i == 0 && j == 0) index = a;
        else if (k == 0 && j == 0) index = b;
        else if (k == 0 && i == 0) index = c;
        else if (j == 0) index = edge_point(a, b, i);
        else if (i == 0) index = edge_point(a, c, j);
        else if (k == 0) index = edge_point(b, c, j);
        else {
          index = static_cast<std::int32_t>(mesh.vertices.size());
          mesh.vertices.push_back((static_cast<double>(k) * corner[a] + static_cast<double>(i) * corner[b] +
                                   static_cast<double>(j) * corner[c])
                                      .normalized());
        }
        lattice[slot(i, j)] = index;
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i + j < n; ++i) {
        mesh.triangles.push_back({lattice[slot(i, j)], lattice[slot(i + 1, j)], lattice[slot(i, j + 1)]});
        if (i + j + 1 < n)
          mesh.triangles.push_back({lattice[slot(i + 1, j)], lattice[slot(i + 1, j + 1)], lattice[slot(i, j + 1)]});
      }
  }
  return mesh;
}

void require_range(bool ok, const std::string& source, const std::string& what) {
  if (!ok) throw core::InputError(source, what);
}

Polyhedron make_ellipsoid(const SolidSpec& spec, const std::string& source) {
  require_range(spec.resolution >= 1 && spec.resolution <= 1000, source,
                "ellipsoid resolution must be between 1 and 1000, got " + std::to_string(spec.resolution));
  require_range(spec.roughness >= 0.0 && spec.roughness <= 0.3, source,
                "ellipsoid roughness must be between 0 and 0.3, got " + core::format_number(spec.roughness));
  geometry::TriangleMesh mesh = geodesic_sphere(spec.resolution);
  if (spec.roughness > 0.0) {
    // Rocky relief: kBumps smooth bumps and dents of random centre and height on the
    // unit sphere, (1 − d²/w²)² within angular chord w of their centre. The relief is a
    // function of direction only, so every resolution samples the same rock. Radii stay
    // above 0.1, so the surface stays star-shaped about the centre and cannot
    // self-intersect.
    constexpr int kBumps = 40;
    constexpr double kWidth = 0.6;  // chord length on the unit sphere (≈ 35°)
    const core::RandomStream rng(spec.seed, core::Stream::block_shape, spec.index);
    std::array<double, 4> draw{};
    std::vector<std::pair<Vec3, double>> bumps;
    for (int k = 0; k < kBumps; ++k) {
      rng.normals(4 * static_cast<std::uint64_t>(k), draw.data(), 4);
      Vec3 centre(draw[0], draw[1], draw[2]);
      if (centre.norm() < 1e-12) centre = Vec3::UnitZ();
      bumps.emplace_back(centre.normalized(), spec.roughness * std::clamp(draw[3], -3.0, 3.0));
    }
    for (Vec3& p : mesh.vertices) {
      double r = 1.0;
      for (const auto& [centre, height] : bumps) {
        // Plain arithmetic: this loop runs 40 times per vertex.
        const double dx = p.x() - centre.x(), dy = p.y() - centre.y(), dz = p.z() - centre.z();
        const double q = (dx * dx + dy * dy + dz * dz) / (kWidth * kWidth);
        if (q < 1.0) r += height * (1.0 - q) * (1.0 - q);
      }
      p *= std::max(r, 0.1);
    }
  }
  for (Vec3& p : mesh.vertices) p = p.cwiseProduct(0.5 * spec.dimensions);
  return geometry::to_polyhedron(mesh);
}

Polyhedron make_rock(const SolidSpec& spec, const std::string& source) {
  require_range(spec.elongation > 0.0 && spec.elongation <= 1.0, source,
                "rock elongation (L2/L1) must be in (0, 1], got " + core::format_number(spec.elongation));
  require_range(spec.flatness > 0.0 && spec.flatness <= 1.0, source,
                "rock flatness (L3/L2) must be in (0, 1], got " + core::format_number(spec.flatness));
  require_range(spec.points >= 8 && spec.points <= 100000, source,
                "rock points must be between 8 and 100000, got " + std::to_string(spec.points));
  const core::RandomStream rng(spec.seed, core::Stream::block_shape, spec.index);
  std::vector<Vec3> pts;
  std::array<double, 3> z{};
  for (int k = 0; k < spec.points; ++k) {
    rng.normals(3 * static_cast<std::uint64_t>(k), z.data(), 3);
    Vec3 d(z[0], z[1], z[2]);
    if (d.norm() < 1e-12) d = Vec3::UnitX();
    pts.push_back(d.normalized().cwiseProduct(Vec3(1.0, spec.elongation, spec.elongation * spec.flatness)));
  }
  Polyhedron poly = convex_hull(pts, source);
  // An affine stretch along the principal axes keeps the hull convex and its faces
  // planar; a few rounds bring the principal extents to the target ratios.
  for (int round = 0; round < 8; ++round) {
    const geometry::MassProperties m = geometry::mass_properties(poly);
    for (Vec3& p : poly.vertices) p -= m.centroid;
    const PrincipalBox box = principal_box(poly, m.inertia);
    const Vec3 want(1.0, spec.elongation, spec.elongation * spec.flatness);
    const Vec3 have = box.lengths / box.lengths[0];
    geometry::Mat3 stretch = geometry::Mat3::Zero();
    for (int i = 0; i < 3; ++i) stretch += (want[i] / have[i]) * box.axes.col(i) * box.axes.col(i).transpose();
    if ((want - have).cwiseAbs().maxCoeff() < 1e-12) break;
    for (Vec3& p : poly.vertices) p = stretch * p;
  }
  return poly;
}

}  // namespace

std::optional<SolidKind> parse_solid_kind(std::string_view name) {
  for (const auto& [kind, text] : kNames)
    if (text == name) return kind;
  return std::nullopt;
}

std::string_view solid_name(SolidKind kind) {
  for (const auto& [k, text] : kNames)
    if (k == kind) return text;
  return "?";
}

Polyhedron small_convex_hull(const std::vector<Vec3>& points, double tolerance) {
  Polyhedron out;
  out.vertices = points;
  std::vector<std::pair<Vec3, double>> planes;
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      for (std::size_t k = j + 1; k < n; ++k) {
        Vec3 normal = (points[j] - points[i]).cross(points[k] - points[i]);
        if (normal.norm() <= tolerance * (points[j] - points[i]).norm()) continue;
        normal.normalize();
        double offset = normal.dot(points[i]);
        int above = 0, below = 0;
        for (const Vec3& p : points) {
          const double s = normal.dot(p) - offset;
          if (s > tolerance) ++above;
          if (s < -tolerance) ++below;
        }
        if (above && below) continue;
        if (above) {
          normal = -normal;
          offset = -offset;
        }
        const bool known = std::any_of(planes.begin(), planes.end(), [&](const auto& pl) {
          return (pl.first - normal).norm() <= 1e-6 && std::abs(pl.second - offset) <= tolerance;
        });
        if (known) continue;
        planes.emplace_back(normal, offset);
        // The face: every point on the plane, in CCW order around the outward normal.
        std::vector<std::int32_t> face;
        Vec3 centre = Vec3::Zero();
        for (std::size_t q = 0; q < n; ++q)
          if (std::abs(normal.dot(points[q]) - offset) <= tolerance) {
            face.push_back(static_cast<std::int32_t>(q));
            centre += points[q];
          }
        centre /= static_cast<double>(face.size());
        const Vec3 u = (points[face[0]] - centre).normalized();
        const Vec3 w = normal.cross(u);
        std::vector<std::pair<double, std::int32_t>> by_angle;
        for (std::int32_t q : face) {
          const Vec3 d = points[q] - centre;
          by_angle.emplace_back(std::atan2(d.dot(w), d.dot(u)), q);
        }
        std::sort(by_angle.begin(), by_angle.end());
        face.clear();
        for (const auto& [angle, q] : by_angle) face.push_back(q);
        out.faces.push_back(std::move(face));
      }
  geometry::remove_unused_vertices(out);
  return out;
}

Polyhedron make_solid(const SolidSpec& spec, const std::string& source) {
  Polyhedron poly;
  switch (spec.kind) {
    case SolidKind::tetrahedron:
    case SolidKind::cube:
    case SolidKind::octahedron:
    case SolidKind::dodecahedron:
    case SolidKind::icosahedron:
      poly = small_convex_hull(platonic_vertices(spec.kind), 1e-9);
      break;
    case SolidKind::box: {
      require_range((spec.dimensions.array() > 0.0).all() && spec.dimensions.allFinite(), source,
                    "box dimensions must be positive");
      std::vector<Vec3> corners;
      for (int k = 0; k < 8; ++k)
        corners.push_back(0.5 * Vec3((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1).cwiseProduct(spec.dimensions));
      poly = small_convex_hull(corners, 1e-12 * spec.dimensions.maxCoeff());
      break;
    }
    case SolidKind::ellipsoid:
      require_range((spec.dimensions.array() > 0.0).all() && spec.dimensions.allFinite(), source,
                    "ellipsoid dimensions must be positive");
      poly = make_ellipsoid(spec, source);
      break;
    case SolidKind::rock:
      poly = make_rock(spec, source);
      break;
  }
  const bool needs_volume = spec.kind != SolidKind::box && spec.kind != SolidKind::ellipsoid;
  if (needs_volume || spec.volume > 0.0) {
    require_range(spec.volume > 0.0 && std::isfinite(spec.volume), source,
                  std::string(solid_name(spec.kind)) + " needs a positive target volume, got " +
                      core::format_number(spec.volume) + " m^3");
    scale(poly, scale_to_volume(volume_of(poly), spec.volume));
  }
  return poly;
}

}  // namespace talus::block
