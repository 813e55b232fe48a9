// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <vector>

#include "block_index.hpp"
#include "talus/dda/model.hpp"
#include "talus/dda/state.hpp"
#include "workspace.hpp"
#include "talus/terrain/terrain.hpp"

namespace talus::dda::detail {

/// The block's placement at the start of a step: world x = centre + F·r_body.
struct Pose {
  Vec3 centre = Vec3::Zero();
  Mat3 rotation = Mat3::Identity();     ///< R
  Mat3 map = Mat3::Identity();          ///< F = R·U
  Mat3 inverse_map = Mat3::Identity();  ///< F⁻¹
  /// F is the rotation R (the 6-DOF path, pose_of): the search then bounds a point's
  /// motion by the rotation's angle rather than by F's Frobenius norm (map_change).
  bool rigid = false;
};

/// The world position (m) of the body point r at `pose`. Every world vertex is computed
/// by this one expression, so a vertex found twice is the same number.
inline Vec3 world_point(const Pose& pose, const Vec3& r) { return pose.centre + pose.map * r; }

/// The block at a pose, as the contact search and the step control see it. A block of few
/// vertices has them all in world coordinates; a detailed block (Model::index) computes
/// only those its index finds near what is asked. Either way vertex(i) and box() are the
/// same numbers.
class PlacedBlock {
 public:
  /// `storage` receives the world vertices of a scanned block (reused from step to step);
  /// `scan` scans a detailed block too (the reference path of the tests). `reuse`, for a
  /// detailed block: the box at an earlier pose (State::scratch_box), taken widened by
  /// how far a vertex can have moved since while that is less than 2 % of the block's
  /// radius, else computed afresh and kept there.
  PlacedBlock(const Model& model, const Pose& pose, std::vector<Vec3>& storage, bool scan = false,
              BlockBox* reuse = nullptr);

  const Model& model() const { return *model_; }
  const Pose& pose() const { return *pose_; }
  /// The block's index, or null when it is scanned.
  const BlockIndex* index() const { return index_; }
  /// World vertex i (m).
  Vec3 vertex(std::size_t i) const { return index_ ? world_point(*pose_, model_->vertices[i]) : (*world_)[i]; }
  /// All world vertices; only for a scanned block (index() null).
  const std::vector<Vec3>& vertices() const { return *world_; }
  /// The box of the world vertices (m): exactly theirs, or, reused from an earlier pose,
  /// a box that holds them. Every use of it only prunes what the exact tests then decide
  /// (a wider box finds the same contacts, in the same order).
  const geometry::Aabb& box() const { return box_; }
  /// A body-frame box holding every body point whose world image (as world_point
  /// computes it) lies in the world box `world`.
  geometry::Aabb body_box(const geometry::Aabb& world) const;
  /// A world box holding the world image (as world_point computes it) of every point of
  /// the body-frame box `body`.
  geometry::Aabb world_box(const geometry::Aabb& body) const;
  /// Bound of the round-off of a world vertex's coordinates (m).
  double round_off() const { return round_off_; }
  /// Bound of the factor by which F⁻¹ lengthens a world distance in the body frame (1 for
  /// a rigid pose).
  double inverse_stretch() const { return inverse_stretch_; }
  /// The block's extent along the world direction u from its centre, max u·(xᵢ − centre)
  /// over the world vertices xᵢ (m for a unit u): a scan, or branch and bound over the
  /// vertex tree of a detailed block, with the same vertices' numbers either way; for a
  /// detailed convex block, an upper bound within twice a world vertex's round-off of it
  /// (VertexClimb).
  double support(const Vec3& u) const;
  /// support(u) of a detailed convex block (index()->climb not empty), climbing from
  /// vertex `from` (−1: the climb's own start), which receives the vertex found; `lever`
  /// receives that vertex's world offset from the centre (m).
  double climbed_support(const Vec3& u, std::int32_t& from, Vec3& lever) const;
  /// An upper bound of support(u) in constant time for a detailed block (that of its
  /// body-frame vertex box, round-off included); support(u) for a scanned one.
  double support_bound(const Vec3& u) const;

 private:
  const Model* model_;
  const Pose* pose_;
  const BlockIndex* index_ = nullptr;
  const std::vector<Vec3>* world_;
  Mat3 abs_inverse_;
  double round_off_ = 0.0;
  double inverse_stretch_ = 1.0;
  geometry::Aabb box_;
};

/// Finds every block–terrain contact candidate within `search_distance` (m) of the block
/// `at`: block vertex – terrain triangle, terrain vertex – block face, block edge – terrain
/// ridge edge. Candidates deeper than `depth_limit` (m) are ignored (they belong to another
/// side of the terrain). Terrain features come from `patch`, re-gathered (with a margin)
/// only when the block's search box leaves it. Appends to `out` (geometric fields only).
/// A detailed block's features are found through its index, with the same contacts in
/// the same order as scanning them all would give.
///
/// `filter` narrows the search beyond its distances (SearchFilter).
struct MotionFilter;
/// What a search leaves out beyond its distances: an explicit filter of the caller's.
struct SearchFilter {
  /// When positive and less than the search distance (m), narrows a detailed block's
  /// search: its vertex–triangle and edge–ridge pairs only within this distance; terrain
  /// vertex – block face contacts (whose choice of face depends on the distance) and the
  /// patch still within the search distance. The contacts are then those of the full
  /// search less its vertex–triangle and edge–ridge contacts with a gap of near_distance
  /// or more, in the same order with the same numbers. A scanned block ignores it.
  double near_distance = 0.0;
  /// When given, a rigid detailed block's search within near_distance passes over the
  /// candidates this filter shows cannot close under a bounded motion (MotionFilter).
  MotionFilter* motion = nullptr;
  /// Crosses the block's edges with every valley of the terrain, whatever their length
  /// (Model::crosses_valleys decides otherwise).
  bool every_valley = false;
};
void detect_contacts(const PlacedBlock& at, const terrain::Surface& surface, double search_distance,
                     double depth_limit, TerrainPatch& patch, std::vector<Contact>& out,
                     const SearchFilter& filter = {});

/// Candidates a search passes over before they are placed, tested and built: those whose
/// gap, bounded below (less the round-off of the bound), is more than `scale` times what
/// their point moves at a given motion, scale·(|v + ω × r|·h + ½g·h²), with the speed
/// computed in the body frame and 1e-9 of it and `allowance` on top; and whose feature is
/// none of the kept ones.
/// - A vertex–triangle pair: its body-frame gap (BodyPlane); its vertex none of `keep`.
/// - An edge–ridge pair: the ends' level along the ridge's `out` bounds the crossing's
///   gap; the speed |v + ω × r| is convex in r, so largest at an end; none of `keep_edges`.
/// - A terrain vertex, before its face query: its distance to the block's hull, at least
///   |d| − S(d/|d|), bounds its contact's gap; the contact's point, on a face that gap
///   away, moves up to |ω|·h·gap more than the vertex's own point; none of `keep_terrain`.
/// `least_gap` bounds their gaps below, for the caller's check of them as a group.
struct MotionFilter {
  Vec3 velocity = Vec3::Zero();  ///< Fᵀv, the centre's velocity in the body frame (m/s)
  Vec3 spin = Vec3::Zero();      ///< Fᵀω, the spin in the body frame (rad/s)
  double h = 0.0;                ///< the step's length (s)
  double fall = 0.0;             ///< ½g·h², as point_reach computes it (m)
  double scale = 2.0;            ///< the multiple of the motion (-)
  /// The round-off of the world lever x − centre that point_reach turns by ω, times
  /// scale·h (m): 1e-9 of the centre's coordinates and the radius.
  double allowance = 0.0;
  const std::vector<std::int32_t>* keep = nullptr;  ///< ascending vertices never passed over
  const std::vector<std::int32_t>* keep_edges = nullptr;  ///< ascending edges never passed over
  /// Ascending terrain vertices (ids) never passed over.
  const std::vector<std::int32_t>* keep_terrain = nullptr;
  std::size_t passed = 0;        ///< out: candidates passed over
  double least_gap = std::numeric_limits<double>::infinity();  ///< out: the least bound of their gaps (m)

  /// The gap (m) beyond which a candidate whose point moves at `speed` (m/s) is passed over:
  /// scale·(speed·h + ½g·h²), with 1e-9 of it and `allowance` on top.
  double reach(double speed) const { return scale * (speed * h + fall) * (1.0 + 1e-9) + allowance; }
  /// Counts a candidate passed over, its gap bounded below by `low` (m).
  void take(double low) {
    ++passed;
    least_gap = std::min(least_gap, low);
  }
  /// None passed over yet (a search afresh).
  void restart() {
    passed = 0;
    least_gap = std::numeric_limits<double>::infinity();
  }
};

/// Brute-force reference of detect_contacts: every triangle of the surface and every
/// feature of the block, no pruning (`every_valley` as SearchFilter's).
void detect_contacts_brute_force(const Model& model, const terrain::Surface& surface, const Pose& pose,
                                 double search_distance, double depth_limit, std::vector<Contact>& out,
                                 bool every_valley = false);

/// How far apart the hull of the world points `block` and the triangle `corners` lie (m)
/// along the direction from `centre` to the triangle's point nearest to it: a lower
/// bound of their distance (negative when they overlap along it; −∞ when `centre` lies on
/// the triangle), for the flight test's triangles whose plane, continued, passes by the
/// block. `direction`, when given, receives that unit direction (unchanged when there is
/// none).
double separation(const std::vector<Vec3>& block, const Vec3& centre, const std::array<Vec3, 3>& corners,
                  Vec3* direction = nullptr);
/// The same for the block `at` (its extent by PlacedBlock::support).
double separation(const PlacedBlock& at, const std::array<Vec3, 3>& corners, Vec3* direction = nullptr);

/// The free flight of a rigid block as the flight test bounds it (docs/dda.md, The step).
/// The block is the convex hull of its world vertices, and a rigid motion is affine, so
/// the hull stays on one side of a plane while its vertices do. Vertex i at r = pᵢ − c
/// from the centroid c, with velocity wᵢ = v + ω × r, approaches a plane of unit normal n
/// by at most
///   dᵢ(t) = −(n·wᵢ)·t + ½·(g·n_z + |ω|²·|r|)·t²
/// in a time t of free flight. This is the parabola of the centroid exactly, plus the
/// spin's rotation by θ = |ω|·t to first order; the rotation's remainder is at most
/// ½θ²·|r|. For a motion whose velocity is damped step by step (`damped`), the
/// translation's and the spin's approaches count only where positive, and gravity only
/// towards the plane: max(0, −n·v) + max(0, −n·(ω × r)) and g·max(0, n_z). (The engine's
/// flight is never damped, whatever dynamic_coefficient is, so clear_time passes false;
/// the damped form stays a tested bound: DdaFlight.ClearTimeNeverPassesTheFirstTouch.)
class FlightBound {
 public:
  /// `vertices` (world, m) must outlive the bound's use; `round_off` (m) is taken off
  /// every height.
  /// `spin_curvature` (1/s², at least |ω|²) bounds |r̈|/|r| of the rotation over the
  /// flight (rotation_curvature); negative for |ω|², a spin that does not turn.
  void reset(const std::vector<Vec3>& vertices, const Vec3& centre, const Vec3& velocity, const Vec3& spin,
             double gravity, bool damped, double round_off, double spin_curvature = -1.0);
  /// The bound of a detailed block (`at` has an index; it must outlive the bound's use),
  /// after a check in constant time with the block's box and every vertex taken at the
  /// block's radius R (an approach of at most −n·v + |ω|·R, a curvature of at most
  /// g·n_z + |ω|²·R): for a concave block the same times, each vertex's, found by branch
  /// and bound over the vertex tree (a body box bounds its vertices' heights, approaches
  /// and curvatures); for a convex one a time from its support with every curvature at R
  /// (climb_plane_time), never longer. The separation direction's extent is
  /// PlacedBlock::support. Its round-off allowance is a little wider than the scan's.
  void reset(const PlacedBlock& at, const Vec3& velocity, const Vec3& spin, double gravity, bool damped,
             double round_off, double spin_curvature = -1.0);
  /// Times below `enough` (s) need not be exact: a time the bound would give below it may
  /// come out as any time below it that is still proven clear (a detailed convex block's
  /// search then stops once it knows the time is below); one at or above it is the same
  /// number. 0 (every time exact) after each reset.
  void settle_below(double enough) { enough_ = enough; }
  /// The earliest time (s) at which a vertex may reach the plane {x : n·x = offset}
  /// from the side n points to, or `limit` if none can before it; 0 when a vertex is not
  /// on that side.
  double plane_time(const Vec3& n, double offset, double limit) const;
  /// How long (s, at most `limit`) the block stays clear of the triangle `corners` (unit
  /// normal `normal`): while its vertices stay above the triangle's plane, or, failing
  /// that, short of the triangle's extent along the direction from the centroid to the
  /// triangle's nearest point (separation).
  double triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const;
  /// A lower bound of triangle_time in constant time, for a detailed block (its box's
  /// height above the triangle's plane instead of its support); triangle_time itself
  /// for a scanned one.
  double quick_triangle_time(const Vec3& normal, const std::array<Vec3, 3>& corners, double limit) const;

 private:
  /// A detailed block's plane_time from its box, every vertex at the radius R (a lower
  /// bound, in constant time; 0 when the box reaches the plane).
  double box_plane_time(const Vec3& n, double offset, double limit) const;
  /// A detailed convex block's plane_time, from its support (VertexClimb).
  double climb_plane_time(const Vec3& n, double offset, double limit) const;

  const std::vector<Vec3>* vertices_ = nullptr;
  const PlacedBlock* placed_ = nullptr;  // a detailed block's (then vertices_ is null)
  double spin_ = 0.0, radius_ = 0.0;     // |ω| (rad/s) and R (m) of a detailed block
  Vec3 spin_vector_ = Vec3::Zero();      // ω (rad/s) of a detailed block
  Vec3 centre_ = Vec3::Zero(), velocity_ = Vec3::Zero();
  double gravity_ = 0.0, round_off_ = 0.0;
  double turning_ = 0.0;  // spin_curvature − |ω|² (1/s²): 0 for a spin that does not turn
  double enough_ = 0.0;  // settle_below (s)
  bool damped_ = false;
  std::vector<Vec3> rates_;        // per vertex: wᵢ, or ω × r when damped (m/s)
  std::vector<double> curvature_;  // per vertex: |ω|²·|r| (m/s²)
};

}  // namespace talus::dda::detail
