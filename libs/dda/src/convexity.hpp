#pragma once
// An exact side-of-plane test for the block's convexity (model.cpp). Its own translation
// unit keeps CGAL's kernel out of the engine's other sources.

#include "talus/dda/model.hpp"

namespace talus::dda::detail {

/// Whether w lies on the plane of the triangle (a, b, c) or behind it, the side away from
/// (b − a) × (c − a): decided exactly on the given coordinates, with no round-off.
bool on_or_behind(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& w);

}  // namespace talus::dda::detail
