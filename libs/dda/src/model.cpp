// SPDX-License-Identifier: MIT
#include "talus/dda/model.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>

#include "block_index.hpp"
#include "convexity.hpp"
#include "talus/core/error.hpp"

namespace talus::dda {

namespace {
// The presets' time steps (s), from the run time against error measurements.
constexpr double kScreeningTimeStep = 2e-3;
constexpr double kResearchTimeStep = 2e-4;
}  // namespace

void apply_preset(Settings& s, const std::string& preset) {
  // Measured by bench/pareto/pareto.py (docs/benchmarks.md, "Run time against error of the
  // study's outputs", main f828692): screening 12.5, design 19.9, research 93.4 ms per
  // realization, all three within sampling noise of the 0.1 ms reference on that study.
  const Settings design;
  s.preset = preset;
  s.dof = design.dof;
  s.time_step = design.time_step;
  s.penalty_omega = design.penalty_omega;
  s.max_open_close_iterations = design.max_open_close_iterations;
  s.max_displacement_ratio = design.max_displacement_ratio;
  s.rest_step_ratio = design.rest_step_ratio;
  s.flight_step_ratio = design.flight_step_ratio;
  if (preset == "screening") {
    s.time_step = kScreeningTimeStep;
  } else if (preset == "research") {
    s.time_step = kResearchTimeStep;
    s.rest_step_ratio = 1.0;  // the reference: every step nominal
    s.flight_step_ratio = 1.0;
  } else if (preset != "design") {
    throw core::InputError("dda settings", "preset '" + preset + "': expected screening, design or research");
  }
}

// The range of Ω = √(k/m)·Δt in which contacts are well posed (docs/dda.md): softer lets a
// fast small block sink past the penetration limit, stiffer leaves springs whose round-off
// breaks the invariants.
constexpr double kMinOmega = 3.0;
constexpr double kMaxOmega = 300.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Each field's range is part of its declaration: the reader refuses a value outside it
// naming the file and line or the --set key (validate() checks the same declarations on
// settings made in code, and what relates two fields).
void Settings::visit(core::SettingsVisitor& v) {
  // The preset first: reading it sets the fields it names, and the fields that follow
  // in this visit override it where they are given.
  const std::string before = preset;
  v.choice("preset", preset, {"screening", "design", "research"},
           "measured trade of run time against error (docs/dda-run.md, Presets): sets time_step and the "
           "numerical fields it names; fields given explicitly win");
  if (preset != before) apply_preset(*this, preset);
  v.choice("dof", dof, {"rigid6", "full12"},
           "unknowns per block: rigid 6-DOF (fast default) or full 12-DOF DDA with strains");
  v.bounded("time_step", time_step, "s", "nominal time step (a block's scene may shorten it: max_step_travel)",
            core::Range::positive(0.05));
  v.bounded("max_step_travel", max_step_travel, "-",
            "longest travel in one nominal step over the block's circumscribed diameter, at the fastest speed the "
            "scene allows (free fall over the terrain's relief, plus the release velocity): the scene shortens "
            "time_step for blocks that would travel farther; 0 = time_step for every block",
            core::Range::closed(0.0, 1.0));
  v.bounded("min_time_step", min_time_step, "s", "smallest time step the step control may cut to",
            core::Range::positive(0.05));
  v.bounded("max_displacement_ratio", max_displacement_ratio, "-",
            "largest vertex displacement per contact step over the block's circumscribed diameter",
            core::Range::positive(1.0));
  v.bounded("dynamic_coefficient", dynamic_coefficient, "-",
            "share of the end-of-step velocity carried to the next step (1 = fully dynamic)",
            core::Range::closed(0.0, 1.0));
  v.bounded("penalty_stiffness", penalty_stiffness, "N/m",
            "normal contact spring stiffness, 0 = from the block mass: m*(penalty_omega/time_step)^2",
            core::Range{0.0, kInf});
  v.bounded("penalty_omega", penalty_omega, "-",
            "sqrt(k/m)*time_step of one contact spring when penalty_stiffness is 0",
            core::Range::closed(kMinOmega, kMaxOmega));
  v.bounded("shear_stiffness_ratio", shear_stiffness_ratio, "-", "normal over shear contact spring stiffness",
            core::Range{0.0, kInf, true, false});
  v.bounded("max_open_close_iterations", max_open_close_iterations, "-",
            "open-close iterations after which a contact that changes state is held in it",
            core::Range::closed(1.0, 1000.0));
  v.bounded("max_step_energy_gain", max_step_energy_gain, "-",
            "energy gain of a contact step, over kinetic energy + m*g*radius, beyond which the step is redone "
            "shorter; 0 = never",
            core::Range{0.0, kInf});
  v.bounded("penetration_limit_ratio", penetration_limit_ratio, "-",
            "penetration over block diameter that ends a realization as a numerical failure",
            core::Range::positive(0.5));
  v.bounded("gravity", gravity, "m/s^2", "gravitational acceleration (along -z)", core::Range::closed(0.0, 1000.0));
  v.choice("restitution", restitution, {"scaled", "normal_component", "point", "off"},
           "impact-rebound law applied when a contact episode ends");
  v.bounded("impact_min_normal_speed", impact_min_normal_speed, "m/s",
            "normal approach speed of the closing contact point below which a contact episode is rolling/sliding, not an impact",
            core::Range{0.0, kInf});
  v.choice("restitution_bound", restitution_bound, {"normal_approach", "none"},
           "scaled law: remove at most the kinetic energy of the impact's normal approach, or no bound");
  v.bounded("smooth_turn_deg", smooth_turn_deg, "deg",
            "turn of the faces at a vertex below which they stand for a curved surface, 0 = none",
            core::Range::closed(0.0, 90.0));
  v.bounded("rolling_resistance", rolling_resistance, "-",
            "rolling resistance coefficient: a closed contact resists the block's rotation with at most "
            "rolling_resistance * (its distance from the centroid) * (its normal force), 0 = none",
            core::Range::closed(0.0, 1.0));
  v.field("impact_strains", impact_strains,
          "full12: strains respond during impact episodes (else held during impacts)");
  v.bounded("rest_kinetic_energy", rest_kinetic_energy, "J/kg",
            "kinetic energy per unit mass below which the block may be at rest",
            core::Range::closed(0.0, 0.5));
  v.bounded("rest_dwell", rest_dwell, "s", "time below the rest threshold that ends the realization",
            core::Range{0.0, kInf});
  v.bounded("rest_step_ratio", rest_step_ratio, "-",
            "longest contact step of a rigid6 block below slow_kinetic_energy, or below the rest threshold for "
            "rest_dwell/5 or more, over time_step (1 = none longer)",
            core::Range::closed(1.0, 100.0));
  v.bounded("flight_step_ratio", flight_step_ratio, "-",
            "longest flight step of a rigid6 block proven clear of the terrain, over time_step (1 = nominal steps)",
            core::Range::closed(1.0, 64.0));
  v.bounded("slow_kinetic_energy", slow_kinetic_energy, "J/kg",
            "kinetic energy per unit mass below which a rigid6 block outside an impact grows its contact steps up "
            "to rest_step_ratio*time_step, 0 = only in the rest dwell",
            core::Range{0.0, kInf});
  v.bounded("max_time", max_time, "s",
            "simulated-time limit per realization, 0 = 60 s + terrain plan diagonal / (1 m/s)",
            core::Range{0.0, kInf});
  v.bounded("max_steps", max_steps, "-", "accepted-step limit per realization, 0 = none", core::Range{0.0, kInf});
  v.bounded("trajectory_interval", trajectory_interval, "s", "sampled trajectory spacing, 0 = none",
            core::Range{0.0, kInf});
  v.bounded("density", density, "kg/m^3", "block density", core::Range{0.0, kInf, true, false});
  v.bounded("young_modulus", young_modulus, "Pa", "block Young's modulus (full12 only)",
            core::Range{0.0, kInf, true, false});
  v.bounded("poisson_ratio", poisson_ratio, "-", "block Poisson's ratio (full12 only)",
            core::Range{-1.0, 0.5, true, true});
  v.field("check_invariants", check_invariants,
          "check depth and energy invariants at every step (counted per realization; slow)");
  v.field("flight_test", flight_test,
          "move the block without a contact search while no contact can close (off: every step searches and "
          "solves; for measuring what the test saves)");
  v.field("time_phases", time_phases, "time each step phase (reporting only)");
}

namespace {

const char* const kSettings = "dda settings";

// The ranges each field declares (Settings::visit), then what relates two fields.
void validate(const Settings& s) {
  Settings declared = s;
  core::check_ranges([&](core::SettingsVisitor& v) { declared.visit(v); }, kSettings);
  if (!(s.min_time_step <= s.time_step))
    throw core::InputError(kSettings, "time_step = " + core::format_number(s.time_step) +
                                          " s is below min_time_step = " + core::format_number(s.min_time_step) +
                                          " s, the shortest step the step control may cut to");
}

DofPath parse_dof(const std::string& text) {
  if (text == "rigid6") return DofPath::rigid6;
  if (text == "full12") return DofPath::full12;
  throw core::InputError(kSettings, "dof = '" + text + "': expected rigid6 or full12");
}

RestitutionLaw parse_restitution(const std::string& text) {
  if (text == "scaled") return RestitutionLaw::scaled;
  if (text == "normal_component") return RestitutionLaw::normal_component;
  if (text == "point") return RestitutionLaw::point;
  if (text == "off") return RestitutionLaw::off;
  throw core::InputError(kSettings,
                         "restitution = '" + text + "': expected scaled, normal_component, point or off");
}

// Checks the polyhedron is closed and consistently oriented and returns its edges with
// their convexity (exact between two triangles; a flat split edge is neither convex nor
// reflex).
std::vector<BlockEdge> build_edges(const geometry::Polyhedron& poly, const std::vector<BlockFace>& faces,
                                   const std::vector<Vec3>& verts, double tol, bool& reflex) {
  std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> directed;  // edge -> face
  for (std::size_t f = 0; f < poly.faces.size(); ++f) {
    const auto& face = poly.faces[f];
    for (std::size_t k = 0; k < face.size(); ++k) {
      const std::int32_t a = face[k];
      const std::int32_t b = face[(k + 1) % face.size()];
      if (!directed.emplace(std::make_pair(a, b), static_cast<std::int32_t>(f)).second)
        throw core::InputError("block", "edge " + std::to_string(a) + "-" + std::to_string(b) +
                                            " is used twice in the same direction (non-manifold or inconsistent orientation)");
    }
  }
  std::vector<BlockEdge> edges;
  for (const auto& [key, f1] : directed) {
    const auto twin = directed.find({key.second, key.first});
    if (twin == directed.end())
      throw core::InputError("block", "polyhedron is not closed: edge " + std::to_string(key.first) + "-" +
                                          std::to_string(key.second) + " has no opposite face");
    if (key.first > key.second) continue;
    // Convex when the far face lies behind the near face's plane.
    const BlockFace& near = faces[f1];
    const BlockFace& far = faces[twin->second];
    Vec3 far_center = Vec3::Zero();
    for (std::int32_t v : far.vertices) far_center += verts[v];
    far_center /= static_cast<double>(far.vertices.size());
    const bool convex = near.normal.dot(far_center) - near.offset < -tol;
    edges.push_back(BlockEdge{key.first, key.second, convex});
    if (convex || reflex) continue;
    if (near.vertices.size() != 3 || far.vertices.size() != 3) {
      reflex = true;
      continue;
    }
    // The far triangle's vertex off the edge.
    std::int32_t w = far.vertices[0];
    for (const std::int32_t v : far.vertices)
      if (v != key.first && v != key.second) w = v;
    reflex = !detail::on_or_behind(verts[near.vertices[0]], verts[near.vertices[1]], verts[near.vertices[2]], verts[w]);
  }
  return edges;
}

// The smooth surface through the vertices (Model::vertex_normals, vertex_rounding): where
// the faces around a vertex turn by less than `corner` (rad) it is a sphere tangent to the
// vertex normal, of the radius that holds the neighbours on average; from corner/2 to
// corner the radius shrinks linearly to zero, so a vertex turns into a corner gradually.
void build_rounding(Model& m, double corner) {
  const std::size_t n = m.vertices.size();
  std::vector<std::vector<std::int32_t>> faces_at(n);
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (std::int32_t v : m.faces[f].vertices) faces_at[static_cast<std::size_t>(v)].push_back(static_cast<std::int32_t>(f));
  std::vector<std::vector<std::int32_t>> next(n);
  for (const BlockEdge& e : m.edges) {
    next[static_cast<std::size_t>(e.a)].push_back(e.b);
    next[static_cast<std::size_t>(e.b)].push_back(e.a);
  }
  m.vertex_normals.assign(n, Vec3::Zero());
  m.vertex_rounding.assign(n, 0.0);
  m.vertex_cone.assign(n, 0.0);
  m.neighbour_offsets.assign(1, 0);
  m.vertex_neighbours.clear();
  m.face_offsets.assign(1, 0);
  m.vertex_faces.clear();
  const auto angle = [](const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); };
  for (std::size_t v = 0; v < n; ++v) {
    std::sort(next[v].begin(), next[v].end());
    m.vertex_neighbours.insert(m.vertex_neighbours.end(), next[v].begin(), next[v].end());
    m.neighbour_offsets.push_back(static_cast<std::int32_t>(m.vertex_neighbours.size()));
    m.vertex_faces.insert(m.vertex_faces.end(), faces_at[v].begin(), faces_at[v].end());
    m.face_offsets.push_back(static_cast<std::int32_t>(m.vertex_faces.size()));
    const Vec3& p = m.vertices[v];
    Vec3 normal = Vec3::Zero();
    for (std::int32_t f : faces_at[v]) {
      const auto& ids = m.faces[static_cast<std::size_t>(f)].vertices;
      const std::size_t k = static_cast<std::size_t>(std::find(ids.begin(), ids.end(), static_cast<std::int32_t>(v)) - ids.begin());
      const Vec3& a = m.vertices[static_cast<std::size_t>(ids[(k + ids.size() - 1) % ids.size()])];
      const Vec3& b = m.vertices[static_cast<std::size_t>(ids[(k + 1) % ids.size()])];
      normal += angle(a - p, b - p) * m.faces[static_cast<std::size_t>(f)].normal;
    }
    if (!(normal.norm() > 0.0)) continue;
    normal.normalize();
    m.vertex_normals[v] = normal;
    double turn = 0.0, cone = 0.0;
    for (std::int32_t f : faces_at[v]) {
      const Vec3& nf = m.faces[static_cast<std::size_t>(f)].normal;
      cone = std::max(cone, angle(normal, nf));
      for (std::int32_t g : faces_at[v]) turn = std::max(turn, angle(nf, m.faces[static_cast<std::size_t>(g)].normal));
    }
    m.vertex_cone[v] = cone;
    if (!(turn < corner) || next[v].empty()) continue;
    double sum = 0.0;
    bool convex = true;
    for (std::int32_t u : next[v]) {
      const Vec3 d = p - m.vertices[static_cast<std::size_t>(u)];
      const double drop = normal.dot(d);
      if (!(drop > 1e-12 * d.norm())) {
        convex = false;
        break;
      }
      sum += d.squaredNorm() / (2.0 * drop);
    }
    if (!convex) continue;
    const double taper = std::clamp(2.0 * (corner - turn) / corner, 0.0, 1.0);
    const double rho = std::min(m.radius, sum / static_cast<double>(next[v].size())) * taper;
    m.vertex_rounding[v] = rho;
    // A vertex's sphere can reach farthest for directions up to about twice its cone's
    // half-angle from its normal.
    m.rounding_reach = std::max(m.rounding_reach, rho * (1.0 - std::cos(std::min(2.0 * cone, std::numbers::pi / 2))));
  }
}

}  // namespace

Model Model::build(const Settings& settings, const geometry::Polyhedron& block) {
  validate(settings);
  Model m;
  m.settings = settings;
  m.dof = parse_dof(settings.dof);
  m.restitution = parse_restitution(settings.restitution);
  if (settings.restitution_bound != "normal_approach" && settings.restitution_bound != "none")
    throw core::InputError(kSettings, "restitution_bound = '" + settings.restitution_bound +
                                          "': expected normal_approach or none");
  m.bound_by_normal_approach = settings.restitution_bound == "normal_approach";

  if (block.vertices.size() < 4 || block.faces.size() < 4)
    throw core::InputError("block", "a block needs at least 4 vertices and 4 faces");
  for (const Vec3& p : block.vertices)
    if (!p.allFinite()) throw core::InputError("block", "non-finite vertex coordinate");
  for (const auto& face : block.faces) {
    if (face.size() < 3) throw core::InputError("block", "a face has fewer than 3 vertices");
    for (std::int32_t v : face)
      if (v < 0 || static_cast<std::size_t>(v) >= block.vertices.size())
        throw core::InputError("block", "face vertex index " + std::to_string(v) + " out of range");
  }
  const geometry::MassProperties props = geometry::mass_properties(block);
  if (!(props.volume > 0.0))
    throw core::InputError("block", "volume " + core::format_number(props.volume) +
                                        " m^3 is not positive (inside-out or degenerate polyhedron)");

  m.volume = props.volume;
  m.mass = settings.density * props.volume;
  m.second_moments = props.second_moments;
  m.inertia = settings.density * props.inertia;
  const Eigen::SelfAdjointEigenSolver<Mat3> principal(m.inertia);
  m.principal_moments = principal.eigenvalues();
  m.principal_axes = principal.eigenvectors();
  if (m.principal_axes.determinant() < 0.0) m.principal_axes.col(2) *= -1.0;
  m.isotropic = m.principal_moments.maxCoeff() - m.principal_moments.minCoeff() <=
                1e-9 * m.principal_moments.maxCoeff();
  m.vertices.reserve(block.vertices.size());
  for (const Vec3& p : block.vertices) {
    m.vertices.push_back(p - props.centroid);
    m.radius = std::max(m.radius, m.vertices.back().norm());
  }
  const double tol = 1e-9 * m.radius;
  const double thinnest = Eigen::SelfAdjointEigenSolver<Mat3>(m.second_moments).eigenvalues().minCoeff();
  m.size = std::min(2.0 * m.radius, 2.0 * std::sqrt(12.0 * std::max(0.0, thinnest) / m.volume));

  for (const auto& face : block.faces) {
    BlockFace f;
    f.vertices = face;
    // Newell's normal is robust for any planar polygon, convex or not.
    Vec3 n = Vec3::Zero();
    for (std::size_t k = 0; k < face.size(); ++k) {
      const Vec3& a = m.vertices[face[k]];
      const Vec3& b = m.vertices[face[(k + 1) % face.size()]];
      n += Vec3((a.y() - b.y()) * (a.z() + b.z()), (a.z() - b.z()) * (a.x() + b.x()),
                (a.x() - b.x()) * (a.y() + b.y()));
    }
    if (!(n.norm() > 1e-12 * m.radius * m.radius))
      throw core::InputError("block", "a face has zero area");
    f.normal = n.normalized();
    f.offset = f.normal.dot(m.vertices[face[0]]);
    for (std::int32_t v : face)
      if (std::abs(f.normal.dot(m.vertices[v]) - f.offset) > 1e-6 * m.radius)
        throw core::InputError("block", "a face is not planar");
    f.u = (m.vertices[face[1]] - m.vertices[face[0]]).normalized();
    f.u = (f.u - f.normal * f.normal.dot(f.u)).normalized();
    f.v = f.normal.cross(f.u);
    for (std::int32_t v : face) f.polygon.emplace_back(f.u.dot(m.vertices[v]), f.v.dot(m.vertices[v]));
    m.faces.push_back(std::move(f));
  }
  bool reflex = false;
  m.edges = build_edges(block, m.faces, m.vertices, tol, reflex);
  for (const BlockEdge& e : m.edges)
    m.longest_edge = std::max(m.longest_edge, (m.vertices[static_cast<std::size_t>(e.b)] -
                                               m.vertices[static_cast<std::size_t>(e.a)]).norm());
  m.convex = !reflex;
  if (settings.smooth_turn_deg > 0.0) build_rounding(m, settings.smooth_turn_deg * std::numbers::pi / 180.0);
  if (m.vertices.size() > detail::kScannedVertices)
    m.index = std::make_shared<const detail::BlockIndex>(detail::make_block_index(m, 1e-6 * m.radius));
  m.elasticity = isotropic_elasticity(settings.young_modulus, settings.poisson_ratio);
  m.stiffness = settings.penalty_stiffness > 0.0
                    ? settings.penalty_stiffness
                    : m.mass * (settings.penalty_omega / settings.time_step) * (settings.penalty_omega / settings.time_step);
  const double omega = std::sqrt(m.stiffness / m.mass) * settings.time_step;
  // The relative rule gives penalty_omega itself up to round-off of the square root.
  if (!(omega >= kMinOmega * (1.0 - 1e-12) && omega <= kMaxOmega * (1.0 + 1e-12)))
    throw core::InputError(kSettings, "penalty_stiffness = " + core::format_number(settings.penalty_stiffness) +
                                          " N/m gives this block (mass " + core::format_number(m.mass) +
                                          " kg) a contact spring with sqrt(k/m)*time_step = " + core::format_number(omega) +
                                          ", outside the well-posed range [3, 300]: set penalty_stiffness to 0 (from the block, "
                                          "penalty_omega) or to a value in that range");
  return m;
}

Eigen::Matrix<double, 3, 12> displacement_matrix(const Vec3& r) {
  const double x = r.x(), y = r.y(), z = r.z();
  Eigen::Matrix<double, 3, 12> t;
  // columns: u0 v0 w0 | rx ry rz | εx εy εz γyz γzx γxy
  t << 1, 0, 0, 0, z, -y, x, 0, 0, 0, z / 2, y / 2,  //
      0, 1, 0, -z, 0, x, 0, y, 0, z / 2, 0, x / 2,   //
      0, 0, 1, y, -x, 0, 0, 0, z, y / 2, x / 2, 0;
  return t;
}

Mat12 mass_matrix(double density, double volume, const Mat3& second_moments) {
  // T(r) = T0 + Σ r_k T_k; the first moments vanish about the centroid, so
  // ∫TᵀT = V T0ᵀT0 + Σ_kl S_kl T_kᵀ T_l.
  const Eigen::Matrix<double, 3, 12> t0 = displacement_matrix(Vec3::Zero());
  std::array<Eigen::Matrix<double, 3, 12>, 3> tk;
  for (int k = 0; k < 3; ++k) tk[k] = displacement_matrix(Vec3::Unit(k)) - t0;
  Mat12 m = volume * t0.transpose() * t0;
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) m += second_moments(k, l) * tk[k].transpose() * tk[l];
  return density * m;
}

Mat6 isotropic_elasticity(double young_modulus, double poisson_ratio) {
  const double e = young_modulus, nu = poisson_ratio;
  const double lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  const double g = e / (2.0 * (1.0 + nu));
  Mat6 c = Mat6::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) c(i, j) = lambda;
    c(i, i) = lambda + 2.0 * g;
    c(i + 3, i + 3) = g;
  }
  return c;
}

Mat3 rotation_matrix(const Vec3& theta) {
  const double angle = theta.norm();
  if (angle == 0.0) return Mat3::Identity();
  return Eigen::AngleAxisd(angle, theta / angle).toRotationMatrix();
}

}  // namespace talus::dda
