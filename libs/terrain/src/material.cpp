#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "talus/core/error.hpp"
#include "talus/terrain/material_classes.hpp"
#include "talus/terrain/materials.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::terrain {

void Material::visit(core::SettingsVisitor& v) {
  v.field("name", name, "material name");
  visit_material_class(v, class_name, this);
  visit_properties(v, *this);
}

void MaterialZone::visit(core::SettingsVisitor& v) {
  v.field("material", material, "name of the material of this zone");
  v.field("polygon", polygon, "m", "zone outline in plan, [x, y] points in local coordinates (at least 3)");
}

namespace {

using core::format_number;

struct PreparedZone {
  std::int32_t material = 0;
  const std::vector<std::array<double, 2>>* polygon = nullptr;
  double xmin, xmax, ymin, ymax;
};

// Even–odd rule: count edges crossed by the ray from (x, y) towards +x.
bool contains(const PreparedZone& zone, double x, double y) {
  if (x < zone.xmin || x > zone.xmax || y < zone.ymin || y > zone.ymax) return false;
  const auto& poly = *zone.polygon;
  bool inside = false;
  for (std::size_t a = 0, b = poly.size() - 1; a < poly.size(); b = a++) {
    const double xa = poly[a][0], ya = poly[a][1], xb = poly[b][0], yb = poly[b][1];
    if ((ya > y) != (yb > y) && x < xa + (y - ya) / (yb - ya) * (xb - xa)) inside = !inside;
  }
  return inside;
}

Vec3 centroid(const Terrain& terrain, std::size_t t) {
  const auto& tri = terrain.mesh.triangles[t];
  return (terrain.mesh.vertices[static_cast<std::size_t>(tri[0])] + terrain.mesh.vertices[static_cast<std::size_t>(tri[1])] +
          terrain.mesh.vertices[static_cast<std::size_t>(tri[2])]) /
         3.0;
}

void ensure_materials(Terrain& terrain) {
  if (terrain.material_of_triangle.size() != terrain.mesh.triangles.size())
    terrain.material_of_triangle.assign(terrain.mesh.triangles.size(), 0);
}

}  // namespace

void assign_zones(Terrain& terrain, const std::vector<MaterialZone>& zones, const core::SettingsOrigins& origins) {
  std::vector<PreparedZone> prepared;
  prepared.reserve(zones.size());
  for (std::size_t z = 0; z < zones.size(); ++z) {
    const MaterialZone& zone = zones[z];
    const std::string where = "zone " + std::to_string(z) + " (material '" + zone.material + "')";
    const std::string item = "[" + std::to_string(z) + "]";
    const auto it = std::find_if(terrain.materials.begin(), terrain.materials.end(),
                                 [&](const Material& m) { return m.name == zone.material; });
    if (it == terrain.materials.end()) {
      std::string known;
      for (const Material& m : terrain.materials) known += (known.empty() ? "" : ", ") + m.name;
      throw core::InputError(origins.of(item + ".material"),
                             where + ": unknown material '" + zone.material + "' (known: " + known + ")");
    }
    if (zone.polygon.size() < 3) {
      throw core::InputError(
          origins.of(item + ".polygon"),
          where + ": polygon has " + std::to_string(zone.polygon.size()) + " points, at least 3 are needed");
    }
    PreparedZone p;
    p.material = static_cast<std::int32_t>(it - terrain.materials.begin());
    p.polygon = &zone.polygon;
    p.xmin = p.ymin = std::numeric_limits<double>::infinity();
    p.xmax = p.ymax = -std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < zone.polygon.size(); ++k) {
      const auto& q = zone.polygon[k];
      if (!std::isfinite(q[0]) || !std::isfinite(q[1])) {
        throw core::InputError(origins.of(item + ".polygon"),
                               where + ": polygon point " + std::to_string(k) + " is not finite");
      }
      p.xmin = std::min(p.xmin, q[0]);
      p.xmax = std::max(p.xmax, q[0]);
      p.ymin = std::min(p.ymin, q[1]);
      p.ymax = std::max(p.ymax, q[1]);
    }
    prepared.push_back(p);
  }
  ensure_materials(terrain);
  for (std::size_t t = 0; t < terrain.mesh.triangles.size(); ++t) {
    const Vec3 c = centroid(terrain, t);
    for (auto z = prepared.rbegin(); z != prepared.rend(); ++z) {
      if (contains(*z, c.x(), c.y())) {
        terrain.material_of_triangle[t] = z->material;
        break;
      }
    }
  }
}

void assign_material_raster(Terrain& terrain, const DemGrid& ids, const std::string& source) {
  const GridSpec& s = ids.spec;
  if (s.nx < 1 || s.ny < 1 || ids.z.size() != s.point_count() || !(s.dx > 0.0) || !(s.dy > 0.0)) {
    throw core::InputError(source, "material raster is empty or inconsistent (" + std::to_string(s.nx) + " x " +
                                       std::to_string(s.ny) + " points, " + std::to_string(ids.z.size()) +
                                       " values)");
  }
  ensure_materials(terrain);
  const double count = static_cast<double>(terrain.materials.size());
  for (std::size_t t = 0; t < terrain.mesh.triangles.size(); ++t) {
    const Vec3 c = centroid(terrain, t);
    const double fi = std::round((c.x() - s.x0) / s.dx);
    const double fj = std::round((c.y() - s.y0) / s.dy);
    // Messages give positions in the terrain's input coordinates (the raster's own).
    const Vec3& shift = terrain.origin_shift;
    if (!(fi >= 0.0 && fi < s.nx && fj >= 0.0 && fj < s.ny)) {
      throw core::InputError(source, "triangle " + std::to_string(t) + " centroid (" + format_number(c.x() + shift.x()) +
                                         ", " + format_number(c.y() + shift.y()) + ") lies outside the material raster");
    }
    const auto i = static_cast<std::int32_t>(fi);
    const auto j = static_cast<std::int32_t>(fj);
    const double id = ids.z[s.index(i, j)];
    if (!(id >= 0.0 && id < count && id == std::floor(id))) {
      throw core::InputError(source, "material id " + format_number(id) + " at raster point (i=" + std::to_string(i) +
                                         ", j=" + std::to_string(j) + ") at (x=" +
                                         format_number(s.x0 + i * s.dx + shift.x()) +
                                         ", y=" + format_number(s.y0 + j * s.dy + shift.y()) + ") is not in [0, " +
                                         std::to_string(terrain.materials.size()) + ")");
    }
    terrain.material_of_triangle[t] = static_cast<std::int32_t>(id);
  }
}

}  // namespace talus::terrain
