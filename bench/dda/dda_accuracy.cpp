// SPDX-License-Identifier: MIT
// Run time against error: each analytic DDA case over a sweep of Δt, penalty stiffness
// and DOF path; then the 6- and 12-DOF runout distributions on the bench slope.
//
//   dda_accuracy [--realizations N]
//
// Prints Markdown tables (docs/benchmarks.md, "DDA engine").
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "../../tests/dda/dda_cases.hpp"
#include "talus/terrain/build.hpp"
#include "talus/terrain/synthetic.hpp"

namespace {

using namespace talus;
using namespace talus::dda;

constexpr double kG = 9.81;

struct Row {
  double value = 0.0;      // the measured quantity
  double reference = 0.0;  // what it should be
  double error = 0.0;      // |value − reference| (relative where stated)
};

struct Case {
  const char* name;
  const char* measured;  // what value/error mean
  std::function<Row(const Settings&)> run;
};

std::vector<Case> cases() {
  const double th = 30.0 * M_PI / 180.0;
  return {
      {"projectile 2 s", "max position error (m)",
       [](const Settings& s) {
         const testing::FlightResult f = testing::projectile(s, 2.0);
         return Row{f.position_error, 0.0, f.position_error};
       }},
      {"slide 30°, μ = 0.4, 1 s", "relative error of the distance",
       [th](const Settings& s) {
         const double exact = 0.5 * kG * (std::sin(th) - 0.4 * std::cos(th));
         const testing::SlideResult r = testing::on_slope(s, 30.0, 0.4, 1.0);
         return Row{r.distance, exact, std::abs(r.distance / exact - 1.0)};
       }},
      {"stick 30°, μ = 0.6, 10 s", "drift after 0.1 s (m)",
       [](const Settings& s) {
         const testing::SlideResult r = testing::on_slope(s, 30.0, 0.6, 10.0);
         return Row{r.drift, 0.0, r.drift};
       }},
      {"rest on flat ground, 2 s", "relative error of the sink against mg/(4k)",
       [](const Settings& s) {
         const testing::SlideResult r = testing::on_slope(s, 0.0, 0.5, 2.0);
         const double expected = 2800.0 * kG / (4.0 * Model::build(s, testing::cube(1.0)).stiffness);
         return Row{r.mean_sink, expected, std::abs(r.mean_sink / expected - 1.0)};
       }},
      {"normal impact 7 m/s, law", "relative error of the rebound speed",
       [](const Settings& s) {
         const double expected = 0.95 / (1.0 + (7.0 / 12.0) * (7.0 / 12.0)) * 7.0;
         const testing::ReboundResult r = testing::rebound(s, 7.0, 0.95);
         return Row{r.v_out, expected, std::abs(r.v_out / expected - 1.0)};
       }},
      {"normal impact 7 m/s, law off", "raw rebound ratio (reference: Ω)",
       [](const Settings& s) {
         Settings off = s;
         off.restitution = "off";
         const testing::ReboundResult r = testing::rebound(off, 7.0, 0.95);
         return Row{r.v_out / r.v_in, r.omega, std::abs(r.v_out / r.v_in - 1.0)};
       }},
      {"normal impact 7 m/s, law off, impact_strains on", "raw rebound ratio (reference: Ω)",
       [](const Settings& s) {
         Settings off = s;
         off.restitution = "off";
         off.impact_strains = true;
         const testing::ReboundResult r = testing::rebound(off, 7.0, 0.95);
         return Row{r.v_out / r.v_in, r.omega, std::abs(r.v_out / r.v_in - 1.0)};
       }},
      {"spin 10 rad/s, 35 000 steps", "relative volume error",
       [](const Settings& s) {
         const testing::SpinResult r = testing::spin(s, 35000);
         return Row{r.volume_error, 0.0, r.volume_error};
       }},
  };
}

void sweep() {
  struct Point {
    double dt, k;
  };
  std::vector<Point> points;
  for (const double dt : {2e-3, 1e-3, 5e-4, 2.5e-4}) points.push_back({dt, 1e12});
  for (const double k : {1e9, 1e10, 1e11, 1e13}) points.push_back({1e-3, k});
  for (const Case& c : cases()) {
    std::printf("\n### %s — %s\n\n", c.name, c.measured);
    std::printf("| DOF | Δt (s) | k (N/m) | value | reference | error | run time (ms) |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (const char* dof : {"rigid6", "full12"})
      for (const Point& p : points) {
        Settings s;
        s.dof = dof;
        s.time_step = p.dt;
        s.penalty_stiffness = p.k;
        const auto t0 = std::chrono::steady_clock::now();
        const Row r = c.run(s);
        const double ms = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e3;
        std::printf("| %s | %.2g | %.0e | %.6g | %.6g | %.2e | %.1f |\n", dof, p.dt, p.k, r.value, r.reference, r.error, ms);
        std::fflush(stdout);
      }
  }
}

// Runout distributions of the two DOF paths on the rough bench slope (cube, R = 1/4).
void distributions(int n) {
  terrain::Terrain t = terrain::build_grid_terrain(terrain::make_synthetic(terrain::SyntheticSlope{}, "bench"),
                                                   terrain::Diagonal::alternating, 11, "bench");
  t.roughness.sigma = 0.2;
  std::printf("\n### Bench slope, cube 1 m³, R = 1/4, %d realizations\n\n", n);
  std::printf("| DOF | runout mean (m) | runout sd (m) | lateral sd (m) | max speed mean (m/s) | "
              "failures | ms / realization |\n|---|---|---|---|---|---|---|\n");
  for (const char* dof : {"rigid6", "full12"}) {
    Settings set;
    set.dof = dof;
    const Model m = Model::build(set, testing::cube(1.0));
    double sum = 0, sum2 = 0, lat2 = 0, vmax = 0;
    int failures = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      const terrain::Surface surface = terrain::Surface::realize(t, static_cast<std::uint32_t>(i));
      const Ground g{&surface, t.materials};
      Release r;
      r.position = Vec3(1.0, 20.0, 29.0 + 2.5);
      const Summary s = run(m, g, r, core::RandomStream(3, core::Stream::impact, static_cast<std::uint32_t>(i)));
      sum += s.runout;
      sum2 += s.runout * s.runout;
      lat2 += s.lateral * s.lateral;
      vmax += s.max_speed;
      failures += is_failure(s.end) ? 1 : 0;
    }
    const double ms = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e3 / n;
    const double mean = sum / n;
    std::printf("| %s | %.2f | %.2f | %.2f | %.2f | %d | %.1f |\n", dof, mean, std::sqrt(sum2 / n - mean * mean),
                std::sqrt(lat2 / n), vmax / n, failures, ms);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int n = 50;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--realizations") == 0 && i + 1 < argc) {
      n = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "dda_accuracy: unknown argument '%s' (usage: dda_accuracy [--realizations N])\n", argv[i]);
      return 2;
    }
  }
  sweep();
  if (n > 0) distributions(n);
  return 0;
}
