#include "convexity.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace talus::dda::detail {

bool on_or_behind(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& w) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  const auto point = [](const Vec3& p) { return Point(p.x(), p.y(), p.z()); };
  // The sign of det[b − a, c − a, w − a] = ((b − a) × (c − a))·(w − a).
  return CGAL::orientation(point(a), point(b), point(c), point(w)) != CGAL::POSITIVE;
}

}  // namespace talus::dda::detail
