// SPDX-License-Identifier: MIT
// Cost of DDA steps by kind and phase, and of one whole bench-slope realization.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "../../tests/dda/dda_fixtures.hpp"
#include "talus/core/random.hpp"
#include "talus/mc/clearance.hpp"
#include "talus/mc/realization.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/synthetic.hpp"

namespace {

using namespace talus;
using namespace talus::dda;

terrain::Terrain rough_bench_slope() {
  terrain::Terrain t = terrain::build_grid_terrain(terrain::make_synthetic(terrain::SyntheticSlope{}, "bench"),
                                                   terrain::Diagonal::alternating, 11, "bench");
  t.roughness.sigma = 0.2;  // R = 1/4
  return t;
}

void report_phases(benchmark::State& bm, const State& s, double steps) {
  bm.counters["detect_ns"] = 1e9 * s.times.detect / steps;
  bm.counters["assemble_ns"] = 1e9 * s.times.assemble / steps;
  bm.counters["open_close_ns"] = 1e9 * s.times.open_close / steps;
  bm.counters["solve_ns"] = 1e9 * s.times.solve / steps;
  bm.counters["update_ns"] = 1e9 * s.times.update / steps;
  bm.counters["contacts"] = static_cast<double>(s.counters.contacts) / static_cast<double>(s.counters.contact_steps);
}

// The block released at x = 9.5 m, y = 20 m over the 1:1 face of the slope, its lowest
// point `drop` (m) above the ground under it (mc::vertical_clearance), and stepped to its
// first contact step. A block that starts inside the terrain would instead slide on the
// penetration its contacts take as their offset, which is no benchmark of anything:
// the caller skips when first_contact_is_clean is false. (Placed by its bounding
// sphere over the face's plane, as before, the rough face's bumps reached into the
// detailed ellipsoid: it spent the first 50 of its 500 steps coming out of 2.4 cm deep,
// with no contact ever closed to tell.)
State first_contact(const Model& m, const Ground& g, double drop, double rolling_speed = 0.0) {
  Release r;
  r.position = Vec3(9.5, 20.0, g.surface->height_at(9.5, 20.0)->z + std::sqrt(2.0) * m.radius + drop);
  const mc::Clearance clear = mc::vertical_clearance(m, r.position, r.orientation, *g.surface);
  r.position.z() += drop - clear.gap;
  // Down the face (+x, −z) at `rolling_speed` (m/s), spinning as a ball of the block's
  // radius rolls: ω × (−R·n) = −v for the face normal n = (1, 0, 1)/√2.
  r.velocity = rolling_speed * Vec3(1.0, 0.0, -1.0) / std::sqrt(2.0);
  r.angular_velocity = Vec3(0.0, rolling_speed / m.radius, 0.0);
  State s = start(m, r, core::RandomStream(1, core::Stream::impact, 0));
  Workspace ws;
  while (s.counters.contact_steps == 0) step(m, g, s, ws);
  return s;
}

// Whether the block of `s` arrived from flight: no contact found already penetrated.
bool first_contact_is_clean(const State& s) {
  return s.counters.offset_contacts == 0 &&
         std::none_of(s.contacts.begin(), s.contacts.end(), [](const Contact& c) { return c.gap_offset < 0.0; });
}

// Batches of 500 steps from `checkpoint`, the last batch's end left in `s`.
void run_batches(benchmark::State& bm, const Model& m, const Ground& g, const State& checkpoint, State& s) {
  std::uint64_t steps = 0;
  Workspace ws;
  for (auto _ : bm) {
    s = checkpoint;
    for (int i = 0; i < 500; ++i) step(m, g, s, ws);
    steps += 500;
  }
  bm.SetItemsProcessed(static_cast<std::int64_t>(steps));
}

// The release clearance (mc::vertical_clearance) of the benchmark's ellipsoid at 20·n²
// faces (Arg 0 n, Arg 1: 1 pruned, 0 every candidate tested), in 64 random orientations at
// points along the rough 1:1 face, 5 cm over the ground: what placing a realization's
// block costs.
void BM_ReleaseClearance(benchmark::State& bm) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 1.0;
  spec.dimensions = Vec3(1.4, 1.2, 1.1);
  spec.resolution = static_cast<int>(bm.range(0));
  const Model m = Model::build(Settings{}, block::make_solid(spec, "bench"));
  const bool prune = bm.range(1) != 0;
  const core::RandomStream rs(7, core::Stream::release, 0);
  std::vector<std::pair<Vec3, Eigen::Quaterniond>> placements;
  for (std::uint64_t k = 0; k < 64; ++k) {
    const Eigen::Quaterniond q = mc::uniform_rotation(rs.uniform(4 * k), rs.uniform(4 * k + 1), rs.uniform(4 * k + 2));
    const double x = 8.0 + 4.0 * rs.uniform(4 * k + 3);
    Vec3 p(x, 20.0, surface.height_at(x, 20.0)->z + 2.0 * m.radius);
    p.z() += 0.05 - mc::vertical_clearance(m, p, q, surface).gap;
    placements.emplace_back(p, q);
  }
  double sum = 0.0;
  for (auto _ : bm)
    for (const auto& [p, q] : placements) sum += mc::vertical_clearance(m, p, q, surface, prune).gap;
  benchmark::DoNotOptimize(sum);
  bm.SetItemsProcessed(static_cast<std::int64_t>(bm.iterations()) * 64);
  bm.counters["faces"] = static_cast<double>(m.faces.size());
}
BENCHMARK(BM_ReleaseClearance)->ArgsProduct({{1, 5, 16, 32}, {0, 1}});

// A 1 m³ dodecahedron (6-DOF) settled on the first bench of the rough slope: the cost
// of a contact step at rest. Arg 1 turns the per-phase timers on.
void BM_ContactStepResting(benchmark::State& bm) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  const Ground g{&surface, t.materials};
  Settings set;
  set.rest_dwell = 1e9;
  set.max_steps = 1 << 30;
  set.max_time = 1e9;
  set.time_phases = bm.range(0) != 0;
  const Model m = Model::build(set, testing::solid(block::SolidKind::dodecahedron, 1.0));
  Release r;
  r.position = Vec3(7.0, 20.0, surface.height_at(7.0, 20.0)->z + 1.0);
  State s = start(m, r, core::RandomStream(1, core::Stream::impact, 0));
  Workspace ws;
  for (int i = 0; i < 3000; ++i) step(m, g, s, ws);
  s.times = PhaseTimes{};
  const std::uint64_t before = s.counters.contact_steps;
  for (auto _ : bm) step(m, g, s, ws);
  if (s.end != EndReason::running) bm.SkipWithError(("the resting block ended: " + std::to_string(static_cast<int>(s.end))).c_str());
  report_phases(bm, s, static_cast<double>(s.counters.contact_steps - before));
  bm.SetItemsProcessed(bm.iterations());
}
BENCHMARK(BM_ContactStepResting)->Arg(0)->Arg(1);

// The dodecahedron rolling and sliding down the rough 1:1 slope: batches of 500 contact
// steps from the same checkpoint.
void BM_ContactStepMoving(benchmark::State& bm) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  const Ground g{&surface, t.materials};
  Settings set;
  set.time_phases = bm.range(0) != 0;
  const Model m = Model::build(set, testing::solid(block::SolidKind::dodecahedron, 1.0));
  const State checkpoint = first_contact(m, g, 0.3);
  if (!first_contact_is_clean(checkpoint)) bm.SkipWithError("the block started inside the terrain");
  State s;
  run_batches(bm, m, g, checkpoint, s);
  bm.counters["contact_share"] = static_cast<double>(s.counters.contact_steps - checkpoint.counters.contact_steps) / 500.0;
  if (set.time_phases) {
    State delta = s;
    delta.times.detect -= checkpoint.times.detect;
    delta.times.assemble -= checkpoint.times.assemble;
    delta.times.open_close -= checkpoint.times.open_close;
    delta.times.solve -= checkpoint.times.solve;
    delta.times.update -= checkpoint.times.update;
    report_phases(bm, delta, 500.0);
  }
}
BENCHMARK(BM_ContactStepMoving)->Arg(0)->Arg(1);

// A detailed block rolling down the rough 1:1 slope: a 1 m³ ellipsoid of diameters
// 1.4 × 1.2 × 1.1 m meshed with 20·n² triangles (Arg n: 20, 500, 1280, 5120 and 20480
// faces),
// batches of 500 steps from the same checkpoint. The cost of a step should hardly grow
// with the face count (the block index, docs/dda.md, Detection).
void contact_step_detailed(benchmark::State& bm, double roughness) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  const Ground g{&surface, t.materials};
  block::SolidSpec spec;
  spec.kind = block::SolidKind::ellipsoid;
  spec.volume = 1.0;
  spec.dimensions = Vec3(1.4, 1.2, 1.1);
  spec.resolution = static_cast<int>(bm.range(0));
  spec.roughness = roughness;
  Settings set;
  set.time_phases = true;  // for the cost per contact step (a few clock reads per step)
  const Model m = Model::build(set, block::make_solid(spec, "bench"));
  const State checkpoint = first_contact(m, g, 0.02, 2.0);
  if (!first_contact_is_clean(checkpoint)) bm.SkipWithError("the block started inside the terrain");
  State s;
  run_batches(bm, m, g, checkpoint, s);
  if (s.end != EndReason::running) bm.SkipWithError("the block stopped within the batch");
  bm.counters["faces"] = static_cast<double>(m.faces.size());
  bm.counters["contact_share"] = static_cast<double>(s.counters.contact_steps - checkpoint.counters.contact_steps) / 500.0;
  const double contact_steps = static_cast<double>(s.counters.contact_steps - checkpoint.counters.contact_steps);
  bm.counters["contacts"] = static_cast<double>(s.counters.contacts - checkpoint.counters.contacts) / contact_steps;
  bm.counters["solved"] = static_cast<double>(s.counters.contacts - checkpoint.counters.contacts -
                                              (s.counters.set_aside_contacts - checkpoint.counters.set_aside_contacts)) /
                          contact_steps;
  const PhaseTimes& a = s.times;
  const PhaseTimes& b = checkpoint.times;
  // Per step of the batch, the time of the contact steps' phases and that of the flight
  // tests (the latter near the ground includes the contact searches that decide a flight
  // of one step; a search a contact step then reuses is counted there).
  bm.counters["contact_us"] = 1e6 *
      (a.detect - b.detect + a.assemble - b.assemble + a.open_close - b.open_close + a.solve - b.solve + a.update - b.update) /
      500.0;
  bm.counters["flight_us"] = 1e6 * (a.flight - b.flight) / 500.0;
  bm.counters["widened"] = static_cast<double>(s.counters.widened_steps - checkpoint.counters.widened_steps) / contact_steps;
  bm.counters["far"] = static_cast<double>(s.counters.far_searches - checkpoint.counters.far_searches) / contact_steps;
}
void BM_ContactStepDetailed(benchmark::State& bm) { contact_step_detailed(bm, 0.0); }
BENCHMARK(BM_ContactStepDetailed)->Arg(1)->Arg(5)->Arg(8)->Arg(16)->Arg(32);

// The same with a rough, concave rock: the ellipsoid with 40 smooth bumps and dents of
// relative height σ = 0.15 (block-gen's rough ellipsoid; the same rock at every
// resolution, 320 to 20 480 faces). A concave block has no vertex climb: its box, extent
// and flight bound go through its vertex tree.
void BM_ContactStepConcave(benchmark::State& bm) { contact_step_detailed(bm, 0.15); }
BENCHMARK(BM_ContactStepConcave)->Arg(4)->Arg(8)->Arg(16)->Arg(32);

// Free flight high above the slope: the exact parabola, no contact search.
void BM_FlightStep(benchmark::State& bm) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  const Ground g{&surface, t.materials};
  const Model m = Model::build(Settings{}, testing::cube(1.0));
  Release r;
  r.position = Vec3(30.0, 20.0, 200.0);
  r.velocity = Vec3(0.0, 0.0, 20.0);
  r.angular_velocity = Vec3(3.0, 1.0, 0.0);
  const State checkpoint = start(m, r, core::RandomStream(1, core::Stream::impact, 0));
  State s;
  Workspace ws;
  std::uint64_t steps = 0;
  for (auto _ : bm) {
    s = checkpoint;
    for (int i = 0; i < 1000; ++i) step(m, g, s, ws);
    steps += 1000;
  }
  if (s.counters.contact_steps != 0) bm.SkipWithError("the flight touched the terrain");
  bm.SetItemsProcessed(static_cast<std::int64_t>(steps));
}
BENCHMARK(BM_FlightStep);

// One deterministic realization: a 1 m³ cube released 2.5 m above the crest of the
// bench slope, R = 1/4 (σ = 0.2 m), 6-DOF, default settings.
void BM_BenchSlopeRealization(benchmark::State& bm) {
  const terrain::Terrain t = rough_bench_slope();
  const terrain::Surface surface = terrain::Surface::realize(t, 0);
  const Ground g{&surface, t.materials};
  Settings set;
  set.dof = bm.range(0) != 0 ? "full12" : "rigid6";
  const Model m = Model::build(set, testing::cube(1.0));
  Release r;
  r.position = Vec3(1.0, 20.0, 29.0 + 2.5);
  Summary out;
  for (auto _ : bm) {
    out = run(m, g, r, core::RandomStream(3, core::Stream::impact, 0));
    benchmark::DoNotOptimize(out.runout);
  }
  bm.counters["steps"] = static_cast<double>(out.steps);
  bm.counters["contact_steps"] = static_cast<double>(out.counters.contact_steps);
  bm.counters["runout_m"] = out.runout;
  bm.counters["sim_time_s"] = out.time;
}
BENCHMARK(BM_BenchSlopeRealization)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
