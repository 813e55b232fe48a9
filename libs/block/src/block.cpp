#include "talus/block/block.hpp"

#include <gmp.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <string>

#include "talus/core/error.hpp"

namespace talus::block {

using geometry::Mat3;
using geometry::Polyhedron;
using geometry::Vec3;

namespace {

// RAII owner of an array of GMP integers.
class MpzArray {
 public:
  explicit MpzArray(std::size_t n) : values_(n) {
    for (auto& v : values_) mpz_init(v);
  }
  MpzArray(const MpzArray&) = delete;
  MpzArray& operator=(const MpzArray&) = delete;
  ~MpzArray() {
    for (auto& v : values_) mpz_clear(v);
  }
  mpz_ptr operator[](std::size_t i) { return values_[i]; }

 private:
  std::vector<mpz_t> values_;
};

}  // namespace

ExactVolume exact_volume(const Polyhedron& poly) {
  // Every finite double is m·2^e with an integer m of at most 53 bits. Shifting all
  // coordinates to the smallest exponent present makes them integers, so 6V·2^(−3E) is
  // an integer sum of 3×3 determinants, computed without rounding.
  int min_exp = INT_MAX;
  for (const Vec3& p : poly.vertices)
    for (int i = 0; i < 3; ++i) {
      if (p[i] == 0.0) continue;
      int e = 0;
      std::frexp(p[i], &e);
      min_exp = std::min(min_exp, e - 53);
    }
  if (min_exp == INT_MAX) return ExactVolume{0.0, std::string(1, '0')};
  ExactVolume out;
  const std::size_t n = poly.vertices.size();
  MpzArray coord(3 * n);
  for (std::size_t v = 0; v < n; ++v)
    for (int i = 0; i < 3; ++i) {
      const double x = poly.vertices[v][i];
      if (x == 0.0) continue;
      int e = 0;
      const double mantissa = std::frexp(x, &e);  // x = mantissa · 2^e, 0.5 ≤ |mantissa| < 1
      mpz_ptr c = coord[3 * v + static_cast<std::size_t>(i)];
      mpz_set_d(c, std::ldexp(mantissa, 53));  // exact: a 53-bit integer
      mpz_mul_2exp(c, c, static_cast<mp_bitcnt_t>(e - 53 - min_exp));
    }
  MpzArray t(5);  // sum, cross component, two products, scratch
  for (const auto& face : poly.faces) {
    for (std::size_t k = 1; k + 1 < face.size(); ++k) {
      const std::size_t a = 3 * static_cast<std::size_t>(face[0]);
      const std::size_t b = 3 * static_cast<std::size_t>(face[k]);
      const std::size_t c = 3 * static_cast<std::size_t>(face[k + 1]);
      // det[a b c] = a · (b × c)
      for (std::size_t i = 0; i < 3; ++i) {
        const std::size_t j = (i + 1) % 3, l = (i + 2) % 3;
        mpz_mul(t[1], coord[b + j], coord[c + l]);
        mpz_submul(t[1], coord[b + l], coord[c + j]);
        mpz_addmul(t[0], coord[a + i], t[1]);
      }
    }
  }
  // V = sum / 6 · 2^(3E)
  mpq_t q;
  mpq_init(q);
  mpq_set_z(q, t[0]);
  mpz_set_ui(t[2], 6);
  mpq_set_den(q, t[2]);
  mpq_canonicalize(q);
  const long shift = 3L * min_exp;
  if (shift >= 0) mpq_mul_2exp(q, q, static_cast<mp_bitcnt_t>(shift));
  else mpq_div_2exp(q, q, static_cast<mp_bitcnt_t>(-shift));
  out.value = mpq_get_d(q);
  std::string text(mpz_sizeinbase(mpq_numref(q), 10) + mpz_sizeinbase(mpq_denref(q), 10) + 3, '\0');
  mpq_get_str(text.data(), 10, q);
  out.rational = text.c_str();
  mpq_clear(q);
  return out;
}

namespace {

// The face whose normal has the largest area-weighted component in the plane spanned
// by `basis` (1 or 2 orthonormal columns of the tied subspace) gives the direction
// there. Faces within a relative 1e-9 of the best are symmetric equivalents, so taking
// the first keeps the result independent of the input's orientation.
bool direction_from_faces(const Polyhedron& poly, const std::vector<Vec3>& subspace, Vec3& dir) {
  double best = 0.0;
  std::vector<Vec3> candidates;
  std::vector<double> scores;
  for (const auto& face : poly.faces) {
    Vec3 an = Vec3::Zero();
    for (std::size_t k = 0; k < face.size(); ++k)
      an += poly.vertices[face[k]].cross(poly.vertices[face[(k + 1) % face.size()]]);
    Vec3 projected = Vec3::Zero();
    for (const Vec3& b : subspace) projected += an.dot(b) * b;
    const double s = projected.norm();
    candidates.push_back(projected);
    scores.push_back(s);
    best = std::max(best, s);
  }
  if (best <= 0.0) return false;
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (scores[i] >= best * (1.0 - 1e-9)) {
      dir = candidates[i] / scores[i];
      return true;
    }
  return false;
}

// Principal axes made unique where moments tie (see Block::dimensions).
Mat3 canonical_axes(const Polyhedron& centred, const Vec3& moments, Mat3 axes) {
  const double scale = std::max(std::abs(moments[2]), 1e-300);
  const bool tie01 = std::abs(moments[1] - moments[0]) <= 1e-9 * scale;
  const bool tie12 = std::abs(moments[2] - moments[1]) <= 1e-9 * scale;
  if (tie01 && tie12) {
    Vec3 d1;
    if (!direction_from_faces(centred, {axes.col(0), axes.col(1), axes.col(2)}, d1)) return axes;
    // Orthonormal basis of the plane normal to d1.
    const Vec3 helper = std::abs(d1.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 u = d1.cross(helper).normalized();
    const Vec3 w = d1.cross(u);
    Vec3 d2;
    if (!direction_from_faces(centred, {u, w}, d2)) d2 = u;
    axes.col(0) = d1;
    axes.col(1) = d2;
    axes.col(2) = d1.cross(d2);
  } else if (tie01 || tie12) {
    const int fixed = tie01 ? 2 : 0;
    const int a = tie01 ? 0 : 1, b = tie01 ? 1 : 2;
    Vec3 d;
    if (!direction_from_faces(centred, {axes.col(a), axes.col(b)}, d)) return axes;
    axes.col(a) = d;
    axes.col(b) = axes.col(fixed).cross(d);
    if (fixed == 0) axes.col(b) = -axes.col(b);
  }
  return axes;
}

}  // namespace

PrincipalBox principal_box(const Polyhedron& centred, const Mat3& inertia) {
  Eigen::SelfAdjointEigenSolver<Mat3> eig(inertia);
  Mat3 axes = eig.eigenvectors();
  if (axes.determinant() < 0.0) axes.col(2) = -axes.col(2);
  axes = canonical_axes(centred, eig.eigenvalues(), axes);
  std::array<std::pair<double, int>, 3> extent{};
  for (int i = 0; i < 3; ++i) {
    double lo = INFINITY, hi = -INFINITY;
    for (const Vec3& p : centred.vertices) {
      const double s = p.dot(axes.col(i));
      lo = std::min(lo, s);
      hi = std::max(hi, s);
    }
    extent[static_cast<std::size_t>(i)] = {hi - lo, i};
  }
  // Longest first; equal lengths keep the axis order.
  std::stable_sort(extent.begin(), extent.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  PrincipalBox box;
  for (int i = 0; i < 3; ++i) {
    box.lengths[i] = extent[static_cast<std::size_t>(i)].first;
    box.axes.col(i) = axes.col(extent[static_cast<std::size_t>(i)].second);
  }
  return box;
}

double scale_to_volume(double volume, double target_volume) { return std::cbrt(target_volume / volume); }

void set_density(Block& block, double density) {
  block.density = density;
  block.mass = density * block.volume_exact;
  block.inertia = density * block.inertia_per_density;
  Eigen::SelfAdjointEigenSolver<Mat3> eig(block.inertia);
  block.principal_moments = eig.eigenvalues();
}

Block make_block(const std::string& name, const Polyhedron& input_frame, double density,
                 const std::string& source) {
  if (!(density > 0.0) || !std::isfinite(density))
    throw core::InputError(source, "density must be positive, got " + core::format_number(density) + " kg/m^3");
  for (const Vec3& p : input_frame.vertices)
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e9)
      throw core::InputError(source, "vertex (" + core::format_number(p.x()) + ", " + core::format_number(p.y()) + ", " +
                                         core::format_number(p.z()) + ") m: coordinates must be finite and in [-1e9, 1e9] m");
  const geometry::MassProperties input_mass = geometry::mass_properties(input_frame);
  if (input_mass.volume >= 0.0 && input_mass.volume < kMinVolume)
    throw core::InputError(source, "block volume " + core::format_number(input_mass.volume) +
                                       " m^3 is outside [1e-06, 1e+06] m^3 (check the scale or volume setting)");
  if (!(input_mass.volume > 0.0))
    throw core::InputError(source, "block has no positive volume (" + core::format_number(input_mass.volume) +
                                       " m^3)");
  // Before the exact arithmetic, which cannot take the non-finite products of a huge block.
  if (!(input_mass.volume >= kMinVolume && input_mass.volume <= kMaxVolume))
    throw core::InputError(source, "block volume " + core::format_number(input_mass.volume) +
                                       " m^3 is outside [1e-06, 1e+06] m^3 (check the scale or volume setting)");
  Block b;
  b.name = name;
  b.source = source;
  b.centroid = input_mass.centroid;
  b.translation = input_mass.centroid;
  b.polyhedron = input_frame;
  for (Vec3& p : b.polyhedron.vertices) p -= input_mass.centroid;

  // The stored (centroid-frame) vertices are what the engine uses: integrate those.
  const geometry::MassProperties m = geometry::mass_properties(b.polyhedron);
  const ExactVolume exact = exact_volume(b.polyhedron);
  b.volume = m.volume;
  b.volume_exact = exact.value;
  b.volume_rational = exact.rational;
  b.second_moments = m.second_moments;
  b.inertia_per_density = m.inertia;
  b.surface_area = m.surface_area;
  b.sphericity = geometry::sphericity(exact.value, m.surface_area);

  Eigen::SelfAdjointEigenSolver<Mat3> eig(m.inertia);
  Mat3 axes = eig.eigenvectors();
  if (axes.determinant() < 0.0) axes.col(2) = -axes.col(2);
  b.principal_axes = axes;
  b.dimensions = principal_box(b.polyhedron, m.inertia).lengths;
  if (b.dimensions.minCoeff() < kMinThicknessRatio * b.dimensions.maxCoeff())
    throw core::InputError(source, "block is a sheet, not a solid: " + core::format_number(b.dimensions.minCoeff()) +
                                       " m thick along its thinnest axis, under 1/1000 of its length of " +
                                       core::format_number(b.dimensions.maxCoeff()) + " m");
  set_density(b, density);
  return b;
}

}  // namespace talus::block
