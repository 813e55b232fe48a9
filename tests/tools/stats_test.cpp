// End-to-end tests of the stats executable on small run files written with the run-file
// writer (values known in advance): tables against independently computed numbers, hazard
// rasters and vector layers in terrain coordinates, shards against the whole run,
// comparisons, plots, and bad inputs (missing, corrupt, empty, incompatible run files; plots drawn without Python).
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_api.h>
#include <ogr_srs_api.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "../mc/mc_fixtures.hpp"
#include "tool_run.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/io/raster.hpp"
#include "talus/io/run_file.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/stats/sample.hpp"

namespace talus {
namespace {

namespace fs = std::filesystem;
using geometry::Vec3;

using testing::read_text;
using Outcome = testing::ToolOutcome;

constexpr std::uint32_t kRealizations = 12;
const mc::HazardGridSpec kGrid{0.0, 0.0, 4.0, 15, 5};
// The terrain lies at projected coordinates: rasters must carry this shift.
const Vec3 kShift(500000.0, 4200000.0, 300.0);

// Runouts of the realizations (12 distinct values).
double runout_of(std::uint32_t i) { return 20.0 + 3.7 * std::fmod(i * 7.0, 12.0) + 0.01 * i; }

// How realization i ended: 11 fails numerically, 4 and 9 leave the terrain (their stop
// class i mod 5 is 'out of domain'), 7 is cut by the step limit; the others rest.
dda::EndReason end_of(std::uint32_t i) {
  if (i == 11) return dda::EndReason::non_finite;
  if (i == 4 || i == 9) return dda::EndReason::left_terrain;
  if (i == 7) return dda::EndReason::step_limit;
  return dda::EndReason::rest;
}

// The realizations whose runouts enter the distributions: those that ended at rest.
std::vector<std::uint32_t> resting() {
  std::vector<std::uint32_t> out;
  for (std::uint32_t i = 0; i < 12; ++i)
    if (end_of(i) == dda::EndReason::rest) out.push_back(i);
  return out;
}

// A realization with known values: block i mod 2, stop class i mod 5, end end_of(i), a toe
// crossing for even i, hazard visits of cells 0 (every realization) and 16 (i < 4).
mc::RealizationResult realization(std::uint32_t i, double runout_offset = 0.0) {
  mc::RealizationResult r;
  r.record.realization = i;
  r.record.block = static_cast<std::int32_t>(i % 2);
  r.record.end = end_of(i);
  r.record.stop_class = static_cast<std::int32_t>(i % 5);
  r.record.runout = runout_of(i) + runout_offset;
  r.record.lateral = 0.5 * std::sin(i);
  r.record.max_speed = 10.0 + i;
  r.record.max_jump_height = 0.1 * (i + 1);
  r.record.max_kinetic_energy = 1000.0 * (i + 1);
  r.record.release_position = Vec3(1.0, 10.0, 33.0);
  r.record.final_position = Vec3(r.record.runout + 1.0, 10.0 + r.record.lateral, 0.0);
  if (i % 2 == 0) {
    mc::Crossing c;
    c.realization = i;
    c.position = 10.0;
    c.time = 3.0;
    c.height = 0.2 * (i + 1);
    c.kinetic_energy = 500.0 * (i + 1);
    r.crossings.push_back(c);
    c.time = 4.0;  // a second crossing (rolling back): only the first counts
    c.height = 99.0;
    r.crossings.push_back(c);
  }
  r.cells.push_back({0, 100.0 * (i + 1), 0.5, 2.0 + i});
  if (i < 4) r.cells.push_back({16, 50.0 * (i + 1), 1.0 + i, 20.0 - i});
  for (int k = 0; k < 3; ++k) {
    dda::TrajectorySample s;
    s.time = k;
    s.position = Vec3(1.0 + k * 5.0, 10.0, 30.0 - k * 5.0);
    r.trajectory.push_back(s);
  }
  return r;
}

io::RunInfo run_info(const std::string& shard, const std::string& settings = "seed: 1\n") {
  io::RunInfo info;
  info.provenance.tool = "dda-run";
  info.provenance.settings_yaml = settings;
  info.provenance.inputs = "terrain.h5\nblocks.h5\n";
  info.realizations = kRealizations;
  info.shard = shard;
  info.blocks = {"cube", "octahedron"};
  info.stop_classes = {"bench 1", "slope", "run-out", "other", "out of domain"};
  info.barriers = {"toe"};
  info.barrier_lines = {{{36.0, 0.0}, {36.0, 20.0}}};
  info.hazard = kGrid;
  return info;
}

// Writes the realizations i ≡ k (mod n) (all for n = 1) as a run file.
void write_run(const fs::path& path, std::uint32_t k, std::uint32_t n, const std::string& settings = "seed: 1\n",
               double runout_offset = 0.0) {
  const io::RunInfo info = run_info(n == 1 ? "0/1" : std::to_string(k) + "/" + std::to_string(n), settings);
  mc::RunData data;
  data.hazard = mc::HazardAccumulator(info.hazard, info.hazard_relative_accuracy);
  for (std::uint32_t i = k; i < kRealizations; i += n) data.add(realization(i, runout_offset));
  data.sort("test");
  io::write_run_file(path.string(), info, data);
}

// The value of one row of a tidy table.
double csv_value(const std::string& csv, const std::string& key) {
  const auto at = csv.find("\n" + key + ",");
  if (at == std::string::npos) {
    ADD_FAILURE() << "no row " << key;
    return std::nan("");
  }
  const auto start = at + key.size() + 2;
  return std::stod(csv.substr(start, csv.find_first_of(",\n", start) - start));
}

// Type-7 quantile of sorted values, written out again here as the independent reference.
double type7(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double h = (static_cast<double>(v.size()) - 1.0) * p;
  const auto lo = static_cast<std::size_t>(h);
  return lo + 1 < v.size() ? v[lo] + (h - static_cast<double>(lo)) * (v[lo + 1] - v[lo]) : v.back();
}

// Width and height of a PNG file from its IHDR chunk (0, 0 when it is not a PNG).
std::pair<std::uint32_t, std::uint32_t> png_size(const fs::path& path) {
  const std::string bytes = read_text(path);
  if (bytes.size() < 24 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 || bytes.compare(12, 4, "IHDR") != 0)
    return {0, 0};
  const auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(bytes[at + k]);
    return v;
  };
  return {u32(16), u32(20)};
}

class Stats : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("talus_stats_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    terrain::Terrain t = mc::testing::bench_terrain(0.1);
    t.origin_shift = kShift;
    t.crs_wkt = io::resolve_crs("EPSG:32632", "test");
    io::Provenance p;
    p.tool = "test";
    io::write_terrain_file((dir_ / "terrain.h5").string(), t, p);
    write_run(dir_ / "whole.h5", 0, 1);
    for (std::uint32_t k = 0; k < 3; ++k) write_run(dir_ / ("part-" + std::to_string(k) + ".h5"), k, 3);
    write_run(dir_ / "foreign-1.h5", 1, 3, "seed: 2\n");
    // Shards of one run written in chunks of 2 and 64: outputs.chunk does not change records.
    write_run(dir_ / "chunked-0.h5", 0, 2, "seed: 1\noutputs:\n  chunk: 2\n");
    write_run(dir_ / "chunked-1.h5", 1, 2, "seed: 1\noutputs:\n  chunk: 64\n");
    write_run(dir_ / "one.h5", 0, 12);  // realization 0 alone (at rest)
    write_run(dir_ / "longer.h5", 0, 1, "seed: 3\n", 5.0);
    io::RunInfo info = run_info("0/1");
    mc::RunData empty;
    empty.hazard = mc::HazardAccumulator(info.hazard, info.hazard_relative_accuracy);
    io::write_run_file((dir_ / "empty.h5").string(), info, empty);
    std::ofstream(dir_ / "corrupt.h5") << "not an HDF5 file\n";
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static Outcome run(const std::vector<std::string>& args, const std::string& env = {}) {
    return testing::run_tool(testing::tool_path("stats"), args, dir_, env);
  }
  // A fast run: no plots, few bootstrap resamples.
  static Outcome run_fast(std::vector<std::string> args) {
    for (const char* a : {"--set", "plots=false", "--set", "bootstrap_resamples=50"}) args.push_back(a);
    return run(args);
  }
  static void expect_one_line_error(const Outcome& o, int code, const std::string& needle) {
    EXPECT_EQ(o.code, code) << o.err;
    EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
    EXPECT_EQ(o.err.rfind("stats: error: ", 0), 0u) << o.err;
    EXPECT_NE(o.err.find(needle), std::string::npos) << o.err;
  }

  static fs::path dir_;
};
fs::path Stats::dir_;

TEST_F(Stats, TablesAgreeWithIndependentValues) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-whole", "--set", "reach_distances=[36]", "--print-table"});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string csv = read_text(dir_ / "out-whole" / "summary.csv");
  ASSERT_EQ(csv.rfind("run,block,variable,statistic,value,unit\n", 0), 0u);
  // The 8 realizations at rest enter the runout distribution (11 failed; 4, 7, 9 censored).
  std::vector<double> runouts, cube;
  for (std::uint32_t i : resting()) {
    runouts.push_back(runout_of(i));
    if (i % 2 == 0) cube.push_back(runout_of(i));
  }
  double mean = 0.0;
  for (double r : runouts) mean += r / 8.0;
  double ss = 0.0;
  for (double r : runouts) ss += (r - mean) * (r - mean);
  // Sums in another order: 1e-12 relative.
  EXPECT_NEAR(csv_value(csv, "whole,all,runout,mean"), mean, 1e-12 * mean);
  EXPECT_NEAR(csv_value(csv, "whole,all,runout,sd"), std::sqrt(ss / 7.0), 1e-12 * mean);
  EXPECT_EQ(csv_value(csv, "whole,all,runout,n"), 8.0);
  EXPECT_EQ(csv_value(csv, "whole,all,runout,censored"), 3.0);
  EXPECT_EQ(csv_value(csv, "whole,all,runout,min"), *std::min_element(runouts.begin(), runouts.end()));
  EXPECT_NEAR(csv_value(csv, "whole,all,runout,P95"), type7(runouts, 0.95), 1e-12 * mean);
  EXPECT_NEAR(csv_value(csv, "whole,cube,runout,P25"), type7(cube, 0.25), 1e-12 * mean);
  EXPECT_LE(csv_value(csv, "whole,all,runout,P50_ci_low"), type7(runouts, 0.5));
  EXPECT_GE(csv_value(csv, "whole,all,runout,P50_ci_high"), type7(runouts, 0.5));
  // DKW at 95 % for n = 8: sqrt(ln 40 / 16).
  EXPECT_NEAR(csv_value(csv, "whole,all,runout,dkw_epsilon"), std::sqrt(std::log(40.0) / 16.0), 1e-15);
  // Mean relative error s/(√n·x̄) and realizations needed n·(RE/0.01)².
  const double re = std::sqrt(ss / 7.0) / std::sqrt(8.0) / mean;
  EXPECT_NEAR(csv_value(csv, "whole,all,runout,mean_relative_error"), re, 1e-12 * re);
  EXPECT_EQ(csv_value(csv, "whole,all,runout,mean_realizations_needed"), std::ceil(8.0 * re * re * 1e4));
  // Fractions over all 12 realizations: stop class i mod 5, toe crossed by even i, failure 11.
  EXPECT_EQ(csv_value(csv, "whole,all,stop:bench 1,count"), 3.0);  // 0, 5, 10
  EXPECT_EQ(csv_value(csv, "whole,all,stop:out of domain,fraction"), 2.0 / 12.0);  // 4, 9
  EXPECT_EQ(csv_value(csv, "whole,all,cross:toe,fraction"), 0.5);
  EXPECT_EQ(csv_value(csv, "whole,all,numerical_failure,count"), 1.0);
  EXPECT_EQ(csv_value(csv, "whole,octahedron,numerical_failure,count"), 1.0);
  // Reaching 36 m: every realization that got there, censored ones included (11 excluded).
  double reach = 0.0;
  for (std::uint32_t i = 0; i < 11; ++i) reach += runout_of(i) >= 36.0 ? 1.0 : 0.0;
  EXPECT_EQ(csv_value(csv, "whole,all,runout>=36,count"), reach);
  // Barrier: the first crossing of each even realization: heights 0.2(i+1), never 99.
  EXPECT_EQ(csv_value(csv, "whole,all,toe.passing_height,n"), 6.0);
  EXPECT_NEAR(csv_value(csv, "whole,all,toe.passing_height,max"), 2.2, 1e-15);
  EXPECT_NEAR(csv_value(csv, "whole,all,toe.kinetic_energy,mean"), 500.0 * 6.0, 1e-9);
  EXPECT_EQ(csv_value(csv, "whole,all,toe.passing_height,missing"), 5.0);
  // Blocks of one run are compared with each other: KS distance of cube and octahedron.
  const std::string cmp = read_text(dir_ / "out-whole" / "comparison.csv");
  EXPECT_NE(cmp.find("\nmax_speed,whole,cube,whole,octahedron,6,5,"), std::string::npos) << cmp;
  // Side-by-side table on standard output and as CSV.
  EXPECT_NE(o.out.find("runout mean (m)"), std::string::npos) << o.out;
  EXPECT_EQ(read_text(dir_ / "out-whole" / "table.csv").rfind("variable,statistic,unit,whole,whole/cube,whole/octahedron\n", 0),
            0u);
  const std::string conv = read_text(dir_ / "out-whole" / "convergence.csv");
  EXPECT_NE(conv.find("\nwhole,all,runout,P95,8,"), std::string::npos) << conv;
  EXPECT_TRUE(fs::file_size(dir_ / "out-whole" / "summary.h5") > 0);
}

TEST_F(Stats, EndReasonsAreReportedAndUnstoppedBlocksCensored) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-ends", "--print-table"});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string csv = read_text(dir_ / "out-ends" / "summary.csv");
  // End reasons over all 12 realizations: 8 rest, 2 left the terrain, 1 step limit, 1 failed.
  EXPECT_EQ(csv_value(csv, "whole,all,end:rest,count"), 8.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:rest,fraction"), 8.0 / 12.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:left_terrain,fraction"), 2.0 / 12.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:step_limit,fraction"), 1.0 / 12.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:non_finite,fraction"), 1.0 / 12.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:no_convergence,count"), 0.0);
  EXPECT_EQ(csv_value(csv, "whole,all,end:penetration,count"), 0.0);
  // Per block: the cube (even i) left the terrain once (4); the octahedron was cut by the
  // step limit (7) and left the terrain (9), and 11 failed: 1, 3, 5 rested.
  EXPECT_EQ(csv_value(csv, "whole,cube,end:left_terrain,count"), 1.0);
  EXPECT_EQ(csv_value(csv, "whole,cube,runout,censored"), 1.0);
  EXPECT_EQ(csv_value(csv, "whole,octahedron,runout,censored"), 2.0);
  EXPECT_EQ(csv_value(csv, "whole,octahedron,runout,n"), 3.0);
  EXPECT_EQ(csv_value(csv, "whole,octahedron,runout,min"), runout_of(1));
  EXPECT_EQ(csv_value(csv, "whole,all,lateral,n"), 8.0);
  EXPECT_EQ(csv_value(csv, "whole,all,lateral,censored"), 3.0);
  // Speeds, heights and energies keep every realization that did not fail (their values
  // so far are real): no censored row.
  EXPECT_EQ(csv_value(csv, "whole,all,max_speed,n"), 11.0);
  EXPECT_EQ(csv_value(csv, "whole,all,max_speed,max"), 20.0);
  EXPECT_EQ(csv_value(csv, "whole,all,max_jump_height,n"), 11.0);
  EXPECT_EQ(csv.find("\nwhole,all,max_speed,censored,"), std::string::npos);
  // A block cut by the step limit stopped nowhere: of stop class 'run-out' (i mod 5 = 2),
  // 2 counts and 7 does not.
  EXPECT_EQ(csv_value(csv, "whole,all,stop:run-out,count"), 1.0);
  // Every realization stopped in one class, was cut by the step limit, or failed.
  double parts = csv_value(csv, "whole,all,end:step_limit,count") + csv_value(csv, "whole,all,numerical_failure,count");
  for (const char* c : {"bench 1", "slope", "run-out", "other", "out of domain"})
    parts += csv_value(csv, std::string("whole,all,stop:") + c + ",count");
  EXPECT_EQ(parts, 12.0);
  // The side-by-side table says how many each runout distribution left out.
  EXPECT_NE(o.out.find("runout censored"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("end:step_limit fraction (-)"), std::string::npos) << o.out;
  const std::string table = read_text(dir_ / "out-ends" / "table.csv");
  EXPECT_NE(table.find("\nrunout,n,,8,5,3\n"), std::string::npos) << table;
  EXPECT_NE(table.find("\nrunout,censored,,3,1,2\n"), std::string::npos) << table;
  // The censored share next to them: 3 of 11, 1 of 6, 2 of 5 (failures are in neither).
  EXPECT_NE(table.find("\nrunout,censored_share,-,0.2727,0.1667,0.4\n"), std::string::npos) << table;
  EXPECT_EQ(csv_value(read_text(dir_ / "out-ends" / "summary.csv"), "whole,all,runout,censored_share"), 3.0 / 11.0);
  EXPECT_EQ(csv_value(read_text(dir_ / "out-ends" / "summary.csv"), "whole,octahedron,lateral,censored_share"), 0.4);
  // Over 10 %: one warning line for the run (not one per block), and the exit code stays 0.
  const std::string warning = "stats: warning: whole: 27 % of the realizations (3 of 11) did not stop on the terrain";
  EXPECT_NE(o.err.find(warning), std::string::npos) << o.err;
  EXPECT_EQ(o.err.find(warning), o.err.rfind("stats: warning: whole:")) << o.err;
  EXPECT_NE(table.find("\nend:rest,fraction,-,0.6667,0.8333,0.5\n"), std::string::npos) << table;
  // summary.h5: the count as an attribute, and stop points of the 8 resting blocks only.
  const io::h5::File h5 = io::h5::File::open((dir_ / "out-ends" / "summary.h5").string());
  const io::h5::Group all = h5.root().open_group("series").open_group("0");
  EXPECT_EQ(all.open_group("variable").open_group("runout").attr_int("censored"), 3);
  EXPECT_EQ(all.open_group("variable").open_group("runout").attr_double("censored_share"), 3.0 / 11.0);
  EXPECT_FALSE(all.open_group("variable").open_group("max_speed").has_attr("censored"));
  EXPECT_EQ(all.read_doubles("stop_points").size(), 16u);
}

TEST_F(Stats, HazardRastersInTerrainCoordinates) {
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-hazard"}).code, 0);
  const terrain::DemGrid reach = io::read_esri_ascii((dir_ / "out-hazard/hazard/whole-reach_probability.asc").string());
  EXPECT_EQ(reach.spec.nx, kGrid.nx);
  EXPECT_EQ(reach.spec.ny, kGrid.ny);
  // Grid points are cell centres, shifted to projected coordinates.
  EXPECT_EQ(reach.spec.x0, kShift.x() + 2.0);
  EXPECT_EQ(reach.spec.y0, kShift.y() + 2.0);
  EXPECT_EQ(reach.z[0], 1.0);         // every realization visits cell 0
  EXPECT_EQ(reach.z[16], 4.0 / 12.0); // realizations 0–3 visit cell 16 = (1, 1)
  EXPECT_EQ(reach.z[2], 0.0);
  const terrain::DemGrid e99 = io::read_geotiff((dir_ / "out-hazard/hazard/whole-energy_p99.tif").string());
  // Exact quantiles at these counts (type 7, h = p(n − 1)): cell 0 energies 100(i+1), P99
  // at h = 10.89 → 1100 + 0.89·100 = 1189 J; cell 16 heights 1…4 m, P95 at h = 2.85 → 3.85 m.
  EXPECT_NEAR(e99.z[0], 1189.0, 1e-9);
  EXPECT_TRUE(std::isnan(e99.z[2]));
  const terrain::DemGrid h95 = io::read_esri_ascii((dir_ / "out-hazard/hazard/whole-height_p95.asc").string());
  EXPECT_NEAR(h95.z[16], 3.85, 1e-12);
  // Passages: the realizations that reached the cell; the mean of cell 0's energies
  // 100 … 1200 J is 650 J (exact).
  const terrain::DemGrid passages = io::read_geotiff((dir_ / "out-hazard/hazard/whole-passage_count.tif").string());
  EXPECT_EQ(passages.z[0], 12.0);
  EXPECT_EQ(passages.z[16], 4.0);
  EXPECT_EQ(passages.z[2], 0.0);
  const terrain::DemGrid e_mean = io::read_geotiff((dir_ / "out-hazard/hazard/whole-energy_mean.tif").string());
  EXPECT_DOUBLE_EQ(e_mean.z[0], 650.0);
  EXPECT_DOUBLE_EQ(e_mean.z[16], 125.0);  // 50, 100, 150, 200 J
  EXPECT_TRUE(std::isnan(e_mean.z[2]));
  // The largest speed and passing height of any passage: exact, not sketched.
  const terrain::DemGrid v_max = io::read_geotiff((dir_ / "out-hazard/hazard/whole-speed_max.tif").string());
  EXPECT_EQ(v_max.z[0], 2.0 + (kRealizations - 1));
  EXPECT_EQ(v_max.z[16], 20.0);
  EXPECT_TRUE(std::isnan(v_max.z[2]));
  const terrain::DemGrid h_max = io::read_geotiff((dir_ / "out-hazard/hazard/whole-height_max.tif").string());
  EXPECT_EQ(h_max.z[0], 0.5);
  EXPECT_EQ(h_max.z[16], 4.0);
  EXPECT_TRUE(std::isnan(h_max.z[2]));
  // Deposits: the realizations that ended at rest, counted in the cell of their stop point.
  std::vector<double> deposits(static_cast<std::size_t>(kGrid.nx * kGrid.ny), 0.0);
  for (std::uint32_t i = 0; i < kRealizations; ++i) {
    const mc::RealizationResult r = realization(i);
    if (r.record.end != dda::EndReason::rest) continue;
    const std::int64_t id = kGrid.cell(r.record.final_position.x(), r.record.final_position.y());
    if (id >= 0) deposits[static_cast<std::size_t>(id)] += 1.0;  // stops beyond the grid are in no cell
  }
  ASSERT_GE(std::accumulate(deposits.begin(), deposits.end(), 0.0), 3.0);
  const terrain::DemGrid deposited = io::read_geotiff((dir_ / "out-hazard/hazard/whole-deposition_count.tif").string());
  EXPECT_EQ(deposited.z, deposits);
  // Every raster carries the terrain's CRS (in the GeoTIFF, and as a .prj beside the .asc)
  // and the GeoTIFFs a band description and unit.
  const std::vector<std::pair<std::string, std::string>> layers = {
      {"reach_probability", "1"}, {"passage_count", "count"}, {"deposition_count", "count"}, {"energy_mean", "J"},
      {"energy_p95", "J"}, {"energy_p99", "J"}, {"height_p95", "m"}, {"height_p99", "m"},
      {"height_max", "m"}, {"speed_max", "m/s"}, {"energy_max", "J"}, {"height_mean", "m"},
      {"speed_mean", "m/s"}, {"speed_p95", "m/s"}, {"speed_p99", "m/s"}};
  for (const auto& [layer, unit] : layers) {
    const fs::path base = dir_ / "out-hazard/hazard" / ("whole-" + layer);
    for (const char* ext : {".tif", ".asc"}) {
      const std::string path = base.string() + ext;
      ASSERT_TRUE(fs::exists(path)) << path;
      EXPECT_EQ(io::crs_name(io::dem_crs(path).text), "WGS 84 / UTM zone 32N (EPSG:32632)") << path;
    }
    const io::BandInfo band = io::read_band_info(base.string() + ".tif");
    EXPECT_EQ(band.unit, unit) << layer;
    EXPECT_FALSE(band.description.empty()) << layer;
  }
}

// Every cell's statistics, in every raster asked for, equal a direct computation from the
// realizations' per-cell values (exact at these counts: type-7 quantiles, means, maxima);
// cells with fewer passages than hazard_min_passages are no data in the statistic rasters
// but keep their counts, stored as Int32.
TEST_F(Stats, CellStatisticsEqualADirectComputation) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-cells", "--set", "hazard_statistics=[mean,median,max]",
                              "--set", "hazard_quantiles=[0.5,0.9,0.95,0.99]", "--set", "hazard_min_passages=5",
                              "--set", "raster_formats=[tif]"});
  ASSERT_EQ(o.code, 0) << o.err;
  std::map<std::int64_t, std::vector<mc::CellVisit>> visits;
  for (std::uint32_t i = 0; i < kRealizations; ++i)
    for (const mc::CellVisit& v : realization(i).cells) visits[v.cell].push_back(v);
  const fs::path dir = dir_ / "out-cells/hazard";
  const std::vector<std::pair<std::string, double>> statistics = {
      {"mean", -1.0}, {"median", 0.5}, {"p50", 0.5}, {"p90", 0.9}, {"p95", 0.95}, {"p99", 0.99}, {"max", 1.0}};
  for (const char* variable : {"energy", "height", "speed"})
    for (const auto& [statistic, p] : statistics) {
      const std::string path = (dir / ("whole-" + std::string(variable) + "_" + statistic + ".tif")).string();
      ASSERT_TRUE(fs::exists(path)) << path;
      const terrain::DemGrid grid = io::read_geotiff(path);
      for (std::size_t k = 0; k < grid.z.size(); ++k) {
        const auto found = visits.find(static_cast<std::int64_t>(k));
        if (found == visits.end() || found->second.size() < 5) {
          EXPECT_TRUE(std::isnan(grid.z[k])) << path << " cell " << k;
          continue;
        }
        std::vector<double> x;
        for (const mc::CellVisit& v : found->second)
          x.push_back(std::string(variable) == "energy" ? v.energy : std::string(variable) == "height" ? v.height : v.speed);
        const stats::Sample direct(x);
        const double expected = p < 0.0 ? direct.mean() : direct.quantile(p);
        EXPECT_DOUBLE_EQ(grid.z[k], expected) << path << " cell " << k;
      }
    }
  // Cell 16 has 4 passages: masked in the statistics, counted in passage_count (Int32).
  const std::string count_path = (dir / "whole-passage_count.tif").string();
  EXPECT_EQ(io::read_geotiff(count_path).z[16], 4.0);
  GDALAllRegister();
  GDALDatasetH ds = GDALOpen(count_path.c_str(), GA_ReadOnly);
  ASSERT_NE(ds, nullptr);
  EXPECT_EQ(GDALGetRasterDataType(GDALGetRasterBand(ds, 1)), GDT_Int32);
  GDALClose(ds);
  ds = GDALOpen((dir / "whole-energy_mean.tif").string().c_str(), GA_ReadOnly);
  ASSERT_NE(ds, nullptr);
  EXPECT_EQ(GDALGetRasterDataType(GDALGetRasterBand(ds, 1)), GDT_Float64);
  GDALClose(ds);
  // A statistic or variable that does not exist is refused in one line.
  const Outcome bad = run_fast({"whole.h5", "-o", "out-bad-stat", "--set", "hazard_statistics=[mode]"});
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("hazard_statistics: 'mode' is not one of: mean, median, max"), std::string::npos) << bad.err;
  const Outcome zero = run_fast({"whole.h5", "-o", "out-bad-min", "--set", "hazard_min_passages=0"});
  EXPECT_NE(zero.code, 0);
  EXPECT_NE(zero.err.find("hazard_min_passages"), std::string::npos) << zero.err;
}

// Intensity and hazard classes from the fixture's per-cell energies (cell 0: 100 … 1200 J
// in 12 of 12 realizations; cell 16: 50 … 200 J in 4), with thresholds 300 J and 1000 J,
// return periods 1, 10, 100 years and a zone releasing 0.5 events per year.
TEST_F(Stats, IntensityFrequencyAndHazardClasses) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-classes", "--set", "intensity_thresholds=[300,1000]", "--set",
                              "return_periods=[1,10,100]", "--set", "release_frequencies=[0.5]", "--set",
                              "raster_formats=[tif]"});
  ASSERT_EQ(o.code, 0) << o.err;
  const fs::path dir = dir_ / "out-classes/hazard";
  const auto layer = [&](const char* name) { return io::read_geotiff((dir / ("whole-" + std::string(name) + ".tif")).string()).z; };
  // Exceedance frequency = 0.5/yr × passages at or above the bound / 12 realizations.
  EXPECT_DOUBLE_EQ(layer("frequency_low")[0], 0.5);
  EXPECT_DOUBLE_EQ(layer("frequency_medium")[0], 0.5 * 10 / 12);  // 300 … 1200 J
  EXPECT_DOUBLE_EQ(layer("frequency_high")[0], 0.5 * 3 / 12);     // 1000, 1100, 1200 J
  EXPECT_DOUBLE_EQ(layer("frequency_low")[16], 0.5 * 4 / 12);
  EXPECT_EQ(layer("frequency_medium")[16], 0.0);
  EXPECT_EQ(layer("frequency_low")[2], 0.0);
  // The T-year energy is the k-th largest passage, k = ⌈12 / (0.5 T)⌉: T = 1 needs 24
  // passages (none: class 0); T = 10, k = 3 → 1000 J (high) and 100 J (low); T = 100, k = 1.
  EXPECT_EQ(layer("intensity_T1")[0], 0.0);
  EXPECT_EQ(layer("intensity_T10")[0], 3.0);
  EXPECT_EQ(layer("intensity_T10")[16], 1.0);
  EXPECT_EQ(layer("intensity_T100")[0], 3.0);
  EXPECT_EQ(layer("intensity_T100")[16], 1.0);
  // Every frequency above is medium (1/10 ≤ f < 1): cell 0 reaches high intensity at a
  // medium frequency (red, 4); cell 16 only low intensity at a medium frequency (yellow, 2).
  EXPECT_EQ(layer("hazard_class")[0], 4.0);
  EXPECT_EQ(layer("hazard_class")[16], 2.0);
  EXPECT_EQ(layer("hazard_class")[2], 0.0);
  EXPECT_EQ(io::read_band_info((dir / "whole-frequency_low.tif").string()).unit, "1/yr");
  // One frequency per run; thresholds must increase.
  const Outcome two = run_fast({"whole.h5", "-o", "out-bad-f", "--set", "release_frequencies=[0.5,1]"});
  EXPECT_NE(two.code, 0);
  EXPECT_NE(two.err.find("release_frequencies: 2 frequencies for 1 runs"), std::string::npos) << two.err;
  const Outcome order = run_fast({"whole.h5", "-o", "out-bad-e", "--set", "intensity_thresholds=[300,30]"});
  EXPECT_NE(order.code, 0);
  EXPECT_NE(order.err.find("intensity_thresholds must be 2 increasing positive values (J)"), std::string::npos)
      << order.err;
}

// The barrier design sheet: the fixture's toe line (20 m) is crossed at 10 m by the even
// realizations (500(i+1) J, 0.2(i+1) m; 0 … 10): with 10 m segments all six fall in the
// second; Q95 and Q99 are type 7 (h = 4.75 and 4.95 of 6 values), in the unit asked for.
TEST_F(Stats, BarrierSheetBySegmentInTheUnitAskedFor) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-sheet", "--set", "energy_unit=kJ"});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string sheet = read_text(dir_ / "out-sheet" / "barrier-sheet.csv");
  EXPECT_EQ(sheet.substr(0, sheet.find('\n')),
            "run,barrier,segment,from_m,to_m,crossings,energy_Q95_kJ,energy_Q95_low_kJ,energy_Q95_high_kJ,"
            "energy_Q99_kJ,energy_Q99_low_kJ,energy_Q99_high_kJ,height_Q95_m,height_Q95_low_m,height_Q95_high_m,"
            "height_Q99_m,height_Q99_low_m,height_Q99_high_m,ead_class_Q99,ead_class_Q99_high");
  EXPECT_NE(sheet.find("\nwhole,toe,1,0,10,0,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,nan,,\n"), std::string::npos)
      << sheet;
  std::vector<std::string> rows;
  for (std::size_t at = 0, next; (next = sheet.find('\n', at)) != std::string::npos; at = next + 1)
    rows.push_back(sheet.substr(at, next - at));
  ASSERT_EQ(rows.size(), 4u) << sheet;  // header, segments 1 and 2, the whole line
  for (const std::size_t k : {2u, 3u}) {
    std::vector<std::string> f;
    std::stringstream line(rows[k]);
    for (std::string cell; std::getline(line, cell, ',');) f.push_back(cell);
    ASSERT_EQ(f.size(), 20u) << rows[k];
    EXPECT_EQ(f[2], k == 2 ? "2" : "all");
    EXPECT_EQ(f[5], "6");
    EXPECT_NEAR(std::stod(f[6]), 5.25, 1e-12);
    EXPECT_NEAR(std::stod(f[9]), 5.45, 1e-12);
    EXPECT_NEAR(std::stod(f[12]), 2.1, 1e-12);
    EXPECT_NEAR(std::stod(f[15]), 2.18, 1e-12);
    EXPECT_LE(std::stod(f[7]), std::stod(f[6]));  // the interval holds the estimate
    EXPECT_GE(std::stod(f[8]), std::stod(f[6]));
    EXPECT_EQ(f[18], "0");  // 5.45 kJ: the smallest EAD class (MEL 100 kJ)
  }
}

TEST_F(Stats, EnergyRastersInKilojoulesOnRequest) {
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-kj", "--set", "energy_unit=kJ"}).code, 0);
  const std::string path = (dir_ / "out-kj/hazard/whole-energy_p99.tif").string();
  EXPECT_NEAR(io::read_geotiff(path).z[0], 1.189, 1e-12);  // 1189 J
  EXPECT_EQ(io::read_band_info(path).unit, "kJ");
  EXPECT_EQ(io::read_band_info((dir_ / "out-kj/hazard/whole-height_p99.tif").string()).unit, "m");
  const Outcome bad = run_fast({"whole.h5", "-o", "out-bad-unit", "--set", "energy_unit=MJ"});
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("energy_unit: 'MJ' is not one of: J, kJ"), std::string::npos) << bad.err;
}

TEST_F(Stats, ShardsGiveTheStatisticsOfTheWholeRun) {
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-ref", "--set", "names=[ref]"}).code, 0);
  const Outcome o = run_fast({"part-2.h5", "part-0.h5", "part-1.h5", "-o", "out-parts", "--set", "names=[ref]"});
  ASSERT_EQ(o.code, 0) << o.err;
  for (const char* file : {"summary.csv", "convergence.csv", "comparison.csv", "table.csv",
                           "hazard/ref-reach_probability.asc", "hazard/ref-energy_p95.asc", "hazard/ref-height_p99.asc"})
    EXPECT_EQ(read_text(dir_ / "out-parts" / file), read_text(dir_ / "out-ref" / file)) << file;
  // Without names the joined run is named after its shards.
  ASSERT_EQ(run_fast({"part-0.h5", "part-1.h5", "part-2.h5", "-o", "out-parts2"}).code, 0);
  EXPECT_NE(read_text(dir_ / "out-parts2" / "summary.csv").find("\npart,all,runout,mean,"), std::string::npos);
  // Shards that differ only in outputs.chunk are one run.
  const Outcome chunked = run_fast({"chunked-0.h5", "chunked-1.h5", "-o", "out-chunked", "--set", "names=[ref]"});
  ASSERT_EQ(chunked.code, 0) << chunked.err;
  EXPECT_EQ(read_text(dir_ / "out-chunked" / "summary.csv"), read_text(dir_ / "out-ref" / "summary.csv"));
  // A run of 12 realizations in 13 shards: the last holds none and still belongs to it.
  std::vector<std::string> thirteen;
  for (std::uint32_t k = 0; k < 13; ++k) {
    const std::string name = "thin-" + std::to_string(k) + ".h5";
    write_run(dir_ / name, k, 13);
    thirteen.push_back(name);
  }
  thirteen.insert(thirteen.end(), {"-o", "out-thin", "--set", "names=[ref]"});
  const Outcome thin = run_fast(thirteen);
  ASSERT_EQ(thin.code, 0) << thin.err;
  EXPECT_EQ(read_text(dir_ / "out-thin" / "summary.csv"), read_text(dir_ / "out-ref" / "summary.csv"));
  expect_one_line_error(run_fast({"thin-12.h5", "-o", "out-bad", "--set", "allow_partial=true"}), 3,
                        "thin-12.h5: the shards given hold no realizations");
}

// A series of one value has no spread: its sd and bootstrap intervals are undefined (nan
// in summary.csv and summary.h5, empty in table.csv), never 0 or an interval of zero width,
// and it has no relative error.
TEST_F(Stats, OneValueHasNoSdAndNoInterval) {
  const Outcome o = run_fast({"one.h5", "-o", "out-one", "--print-table", "--set", "allow_partial=true"});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string csv = read_text(dir_ / "out-one" / "summary.csv");
  EXPECT_EQ(csv_value(csv, "one,all,runout,n"), 1.0);
  EXPECT_EQ(csv_value(csv, "one,all,runout,mean"), runout_of(0));
  EXPECT_EQ(csv_value(csv, "one,all,runout,P95"), runout_of(0));
  EXPECT_NE(csv.find("\none,all,runout,sd,nan,m\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\none,all,runout,P50_ci_low,nan,m\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\none,all,runout,P50_ci_high,nan,m\n"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("one,all,runout,mean_relative_error"), std::string::npos) << csv;
  // The side-by-side table leaves the cell empty ("-" when printed); the one block's
  // series is the run's, so the run is the only column.
  const std::string table = read_text(dir_ / "out-one" / "table.csv");
  EXPECT_NE(table.find("\nrunout,sd,m,\n"), std::string::npos) << table;
  const auto line = o.out.find("runout sd (m)");
  ASSERT_NE(line, std::string::npos) << o.out;
  const std::string printed = o.out.substr(line, o.out.find('\n', line) - line);
  EXPECT_EQ(printed.back(), '-') << printed;
  const io::h5::File h5 = io::h5::File::open((dir_ / "out-one" / "summary.h5").string());
  const io::h5::Group runout = h5.root().open_group("series").open_group("0").open_group("variable").open_group("runout");
  EXPECT_TRUE(std::isnan(runout.attr_double("sd")));
  for (double x : runout.read_doubles("quantile_ci_low")) EXPECT_TRUE(std::isnan(x));
}

TEST_F(Stats, ComparesRunsSideBySide) {
  const Outcome o = run_fast({"whole.h5", "longer.h5", "-o", "out-cmp"});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string cmp = read_text(dir_ / "out-cmp" / "comparison.csv");
  // Runouts of 'longer' are those of 'whole' + 5 m. The KS distance of two 8-value
  // samples (the realizations at rest) is a multiple of 1/8; computed here by brute force
  // over all thresholds.
  std::vector<double> a, b;
  for (std::uint32_t i : resting()) {
    a.push_back(runout_of(i));
    b.push_back(runout_of(i) + 5.0);
  }
  double d = 0.0;
  for (double t : a)
    for (double x : {t, t + 5.0}) {
      const auto fa = static_cast<double>(std::count_if(a.begin(), a.end(), [&](double v) { return v <= x; }));
      const auto fb = static_cast<double>(std::count_if(b.begin(), b.end(), [&](double v) { return v <= x; }));
      d = std::max(d, std::abs(fa - fb) / 8.0);
    }
  const std::string key = "runout,whole,all,longer,all,8,8,";
  const auto at = cmp.find("\n" + key);
  ASSERT_NE(at, std::string::npos) << cmp;
  EXPECT_NEAR(std::stod(cmp.substr(at + key.size() + 1)), d, 1e-15);
  // Same block in two runs is compared; a run's block with the other run's whole is not.
  EXPECT_NE(cmp.find("\nrunout,whole,cube,longer,cube,"), std::string::npos);
  EXPECT_EQ(cmp.find("\nrunout,whole,cube,longer,all,"), std::string::npos);
  // Identical distributions (lateral, speeds …) have D = 0 and p = 1.
  EXPECT_NE(cmp.find("\nmax_speed,whole,all,longer,all,11,11,0,1\n"), std::string::npos) << cmp;
}

// A field test's drop points as several runs, pooled into one series: the pool's
// distributions are those of all its runs' realizations together.
TEST_F(Stats, PoolsSeveralRunsAsOneSeries) {
  const std::string pools = "pools=[{name: drops, runs: [whole, longer]}]";
  const Outcome o = run_fast({"whole.h5", "longer.h5", "-o", "out-pool", "--set", pools});
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string csv = read_text(dir_ / "out-pool" / "summary.csv");
  std::vector<double> runouts;
  for (std::uint32_t i : resting()) {
    runouts.push_back(runout_of(i));
    runouts.push_back(runout_of(i) + 5.0);
  }
  EXPECT_EQ(csv_value(csv, "drops,all,runout,n"), 16.0);
  EXPECT_EQ(csv_value(csv, "drops,all,runout,censored"), 6.0);
  EXPECT_NEAR(csv_value(csv, "drops,all,runout,P50"), type7(runouts, 0.5), 1e-12 * runouts[0]);
  EXPECT_NEAR(csv_value(csv, "drops,all,runout,P95"), type7(runouts, 0.95), 1e-12 * runouts[0]);
  EXPECT_EQ(csv_value(csv, "drops,all,cross:toe,count"), 12.0);  // the even realizations of both
  EXPECT_EQ(csv_value(csv, "drops,all,numerical_failure,count"), 2.0);
  EXPECT_EQ(csv_value(csv, "drops,all,stop:bench 1,fraction"), 6.0 / 24.0);
  EXPECT_EQ(csv_value(csv, "drops,cube,runout,n"), 10.0);  // blocks matched by name: 0, 2, 6, 8, 10 of each
  // The runs themselves are still reported, and an empty list pools every run given.
  EXPECT_EQ(csv_value(csv, "whole,all,runout,n"), 8.0);
  ASSERT_EQ(run_fast({"whole.h5", "longer.h5", "-o", "out-pool2", "--set", "pools=[{name: all-runs}]"}).code, 0);
  EXPECT_EQ(csv_value(read_text(dir_ / "out-pool2" / "summary.csv"), "all-runs,all,runout,n"), 16.0);
  // The pooled stop points, in input coordinates, in its own vector file.
  EXPECT_TRUE(fs::exists(dir_ / "out-pool" / "vector" / "drops.gpkg"));

  expect_one_line_error(run_fast({"whole.h5", "-o", "out-pool3", "--set", "pools=[{name: p, runs: [nope]}]"}), 3,
                        "pools: 'p' names run 'nope', which is not among the runs (whole)");
  expect_one_line_error(run_fast({"whole.h5", "-o", "out-pool3", "--set", "pools=[{name: whole}]"}), 3,
                        "pools: 'whole' is already the name of a run");
}

// Observed stop points (a field campaign) against a series: runout and lateral offset of
// both from the same origin, KS distance, observed quantiles against the simulated band.
TEST_F(Stats, ValidatesASeriesAgainstObservedStopPoints) {
  // The origin (1, 10) in the run's frame: the simulated runout and lateral offset are the
  // records' own (final position = (runout + 1, 10 + lateral)).
  const double ox = 1.0 + kShift.x(), oy = 10.0 + kShift.y();
  const std::vector<double> obs_runout = {25.0, 30.5, 35.0, 41.25, 47.0}, obs_lateral = {0.125, -0.25, 0.375, 0.0, 0.25};
  {
    std::ofstream csv(dir_ / "observed.csv");
    csv << "id,\"Easting\",\"Northing\"\n";
    for (std::size_t k = 0; k < obs_runout.size(); ++k)
      csv << k << "," << std::setprecision(17) << ox + obs_runout[k] << "," << oy + obs_lateral[k] << "\n";
  }
  const std::vector<std::string> settings = {"--set", "observed.file=observed.csv", "--set",
                                             "observed.origin=[" + std::to_string(ox) + "," + std::to_string(oy) + "]"};
  auto args = [&](std::vector<std::string> a) {
    a.insert(a.end(), settings.begin(), settings.end());
    return a;
  };
  const Outcome o = run_fast(args({"whole.h5", "-o", "out-valid"}));
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string csv = read_text(dir_ / "out-valid" / "validation.csv");
  ASSERT_EQ(csv.rfind("series,observed,variable,statistic,value,unit\n", 0), 0u) << csv;
  const std::string key = "whole,observed.csv,";
  EXPECT_EQ(csv_value(csv, key + "runout,n_observed"), 5.0);
  EXPECT_EQ(csv_value(csv, key + "runout,n_simulated"), 8.0);
  std::vector<double> sim_runout, sim_lateral;
  for (std::uint32_t i : resting()) {
    sim_runout.push_back(runout_of(i));
    sim_lateral.push_back(0.5 * std::sin(i));
  }
  // The KS distance by brute force over every value of both samples.
  auto ks = [](const std::vector<double>& a, const std::vector<double>& b) {
    double d = 0.0;
    for (const auto* s : {&a, &b})
      for (double x : *s) {
        const double fa = static_cast<double>(std::count_if(a.begin(), a.end(), [&](double v) { return v <= x; }));
        const double fb = static_cast<double>(std::count_if(b.begin(), b.end(), [&](double v) { return v <= x; }));
        d = std::max(d, std::abs(fa / static_cast<double>(a.size()) - fb / static_cast<double>(b.size())));
      }
    return d;
  };
  EXPECT_NEAR(csv_value(csv, key + "runout,ks_distance"), ks(obs_runout, sim_runout), 1e-12);
  EXPECT_NEAR(csv_value(csv, key + "lateral,ks_distance"), ks(obs_lateral, sim_lateral), 1e-12);
  // Coordinates 2.6e6 m from the origin: the offsets are exact to about 1e-9 m.
  EXPECT_NEAR(csv_value(csv, key + "runout,observed_P50"), type7(obs_runout, 0.5), 1e-8);
  EXPECT_NEAR(csv_value(csv, key + "runout,simulated_P90"), type7(sim_runout, 0.9), 1e-8);
  // The band of the simulated P50 from the DKW ε of 8 values at 95 %: [Q(0.5 − ε), Q(0.5 + ε)].
  const double eps = std::sqrt(std::log(40.0) / 16.0);
  EXPECT_NEAR(csv_value(csv, key + "runout,band_low_P50"), type7(sim_runout, 0.5 - eps), 1e-8);
  EXPECT_NEAR(csv_value(csv, key + "runout,band_high_P50"), type7(sim_runout, std::min(1.0, 0.5 + eps)), 1e-8);
  const double lo = type7(sim_runout, 0.05), hi = type7(sim_runout, 0.95);
  EXPECT_NEAR(csv_value(csv, key + "runout,inside_P5_P95"),
              static_cast<double>(std::count_if(obs_runout.begin(), obs_runout.end(),
                                                [&](double x) { return x >= lo && x <= hi; })) / 5.0,
              1e-15);

  // The same points as a GeoJSON layer in the terrain's CRS give the same table.
  {
    std::ofstream json(dir_ / "observed.geojson");
    json << std::setprecision(17)
         << R"({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32632"}}, "features": [)";
    for (std::size_t k = 0; k < obs_runout.size(); ++k)
      json << (k ? "," : "") << R"({"type": "Feature", "properties": {}, "geometry": {"type": "Point", "coordinates": [)"
           << ox + obs_runout[k] << "," << oy + obs_lateral[k] << "]}}";
    json << "]}\n";
  }
  auto json_args = args({"whole.h5", "-o", "out-valid-json"});
  json_args[json_args.size() - 3] = "observed.file=observed.geojson";
  ASSERT_EQ(run_fast(json_args).code, 0);
  const std::string json_csv = read_text(dir_ / "out-valid-json" / "validation.csv");
  EXPECT_EQ(csv_value(json_csv, "whole,observed.geojson,runout,ks_distance"), csv_value(csv, key + "runout,ks_distance"));
  EXPECT_EQ(csv_value(json_csv, "whole,observed.geojson,lateral,observed_P25"), csv_value(csv, key + "lateral,observed_P25"));
  // In another CRS they are refused, though these runs write no raster, layer or figure
  // (the terrain is read for its CRS all the same).
  {
    std::string text = read_text(dir_ / "observed.geojson");
    text.replace(text.find("EPSG::32632"), 11, "EPSG::2056");
    std::ofstream(dir_ / "observed-2056.geojson") << text;
  }
  json_args = args({"whole.h5", "-o", "out-valid-crs"});
  json_args[json_args.size() - 3] = "observed.file=observed-2056.geojson";
  for (const char* a : {"--set", "hazard_maps=false", "--set", "vector_format=none"}) json_args.push_back(a);
  expect_one_line_error(run_fast(json_args), 3, "not in the terrain's CRS WGS 84 / UTM zone 32N (EPSG:32632)");

  // The validation figure: simulated CDF and band, observed ECDF, for both variables (two
  // panels of 4.6 × 3.6 in at 120 pixels per inch).
  {
    const Outcome plotted = run(args({"whole.h5", "-o", "out-valid-plot", "--set", "bootstrap_resamples=50"}));
    ASSERT_EQ(plotted.code, 0) << plotted.err;
    const fs::path figure = dir_ / "out-valid-plot" / "plots" / "validation.png";
    ASSERT_TRUE(fs::exists(figure));
    EXPECT_GT(fs::file_size(figure), 1000u);
    EXPECT_EQ(png_size(figure), (std::pair<std::uint32_t, std::uint32_t>{1104, 432}));
    // PNG only by default; SVG on request (plot_formats).
    EXPECT_FALSE(fs::exists(dir_ / "out-valid-plot" / "plots" / "validation.svg"));
  }

  // Without observed points the file of an earlier run goes.
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-valid"}).code, 0);
  EXPECT_FALSE(fs::exists(dir_ / "out-valid" / "validation.csv"));

  std::ofstream(dir_ / "observed-bad.csv") << "x,y\n1,2\n3\n";
  auto bad = args({"whole.h5", "-o", "out-valid-bad"});
  bad[bad.size() - 3] = "observed.file=observed-bad.csv";
  expect_one_line_error(run_fast(bad), 3, "observed-bad.csv: line 3: expected the x and y of a stop point");
  expect_one_line_error(run_fast(args({"whole.h5", "-o", "out-valid-bad", "--set", "observed.series=nope"})), 3,
                        "observed.series: no run named 'nope'");
  expect_one_line_error(run_fast({"whole.h5", "-o", "out-valid-bad", "--set", "observed.file=observed.csv"}), 3,
                        "observed.origin must be [x, y]");
  // A stop where no simulated block can stop: past the terrain's edge, or given in the
  // terrain's local frame instead of its input coordinates.
  std::ofstream(dir_ / "observed-off.csv") << std::setprecision(17) << "x,y\n"
                                           << ox + 30.0 << "," << oy << "\n"
                                           << ox + 5000.0 << "," << oy << "\n";
  bad[bad.size() - 3] = "observed.file=observed-off.csv";
  const Outcome off = run_fast(bad);
  expect_one_line_error(off, 3, "observed-off.csv: line 3: observed stop");
  EXPECT_NE(off.err.find("is outside the terrain (input coordinates: x in ["), std::string::npos) << off.err;
  EXPECT_NE(off.err.find("no simulated block can stop there"), std::string::npos) << off.err;
  EXPECT_FALSE(fs::exists(dir_ / "out-valid-bad" / "validation.csv"));
  std::ofstream(dir_ / "observed-local.csv") << "x,y\n31,10\n";
  bad[bad.size() - 3] = "observed.file=observed-local.csv";
  const Outcome local = run_fast(bad);
  EXPECT_EQ(local.code, 3) << local.err;
  EXPECT_NE(local.err.find("observed-local.csv: line 2: observed stop (31, 10)"), std::string::npos) << local.err;
  EXPECT_NE(local.err.find("in its local frame"), std::string::npos) << local.err;
}

TEST_F(Stats, DrawsPlots) {
  // Three threads draw the figures, whatever the machine's core count.
  const Outcome o = run({"whole.h5", "-o", "out-plots", "--set", "bootstrap_resamples=50", "--set", "plot_jobs=3",
                         "--set", "plot_formats=[png,svg]", "--set", "plot_hazard_summary=true"});
  ASSERT_EQ(o.code, 0) << o.err;
  for (const char* stem : {"cdf-runout", "cdf-max_kinetic_energy", "convergence-runout", "barrier-toe", "plan-whole",
                           "hazard-whole", "map-whole-reach_probability", "map-whole-passage_count",
                           "map-whole-energy_p95", "map-whole-speed_max", "sheet-whole-toe"})
    for (const char* ext : {".png", ".svg"}) {
      const fs::path file = dir_ / "out-plots" / "plots" / (std::string(stem) + ext);
      ASSERT_TRUE(fs::exists(file)) << file;
      EXPECT_GT(fs::file_size(file), 1000u) << file;
    }
  // One run, so one panel of 4.6 × 3.6 in; maps are 10 in wide, as high as the terrain's
  // extent asks within 3.4–8.9 in; SVG in points.
  EXPECT_EQ(png_size(dir_ / "out-plots" / "plots" / "cdf-runout.png"), (std::pair<std::uint32_t, std::uint32_t>{552, 432}));
  for (const char* map : {"plan-whole.png", "map-whole-energy_p95.png"}) {
    const auto [width, height] = png_size(dir_ / "out-plots" / "plots" / map);
    EXPECT_EQ(width, 1200u) << map;
    EXPECT_GE(height, 408u) << map;
    EXPECT_LE(height, 1068u) << map;
  }
  const std::string svg = read_text(dir_ / "out-plots" / "plots" / "plan-whole.svg");
  EXPECT_NE(svg.find("width=\"720pt\""), std::string::npos) << svg.substr(0, 300);
  EXPECT_NE(svg.rfind("</svg>"), std::string::npos);
  // Without plot_hazard_summary, one map per raster and no compact figure.
  const Outcome maps = run({"whole.h5", "-o", "out-maps", "--set", "bootstrap_resamples=0"});
  ASSERT_EQ(maps.code, 0) << maps.err;
  EXPECT_FALSE(fs::exists(dir_ / "out-maps" / "plots" / "hazard-whole.png"));
  EXPECT_TRUE(fs::exists(dir_ / "out-maps" / "plots" / "map-whole-height_mean.png"));
  // Drawn again by one thread, every file has the same bytes, and no temporary file is left.
  const Outcome serial = run({"whole.h5", "-o", "out-plots-serial", "--set", "bootstrap_resamples=50", "--set",
                              "plot_jobs=1", "--set", "plot_formats=[png,svg]", "--set", "plot_hazard_summary=true"});
  ASSERT_EQ(serial.code, 0) << serial.err;
  std::size_t compared = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "out-plots" / "plots")) {
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
    const fs::path other = dir_ / "out-plots-serial" / "plots" / entry.path().filename();
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_TRUE(testing::read_text(entry.path()) == testing::read_text(other)) << entry.path().filename();
    ++compared;
  }
  EXPECT_GE(compared, 12u);
  EXPECT_EQ(static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_ / "out-plots-serial" / "plots"),
                                                   fs::directory_iterator{})),
            compared);
}

TEST_F(Stats, PlotsNeedNoPython) {
  // stats draws its figures itself: an interpreter without matplotlib, or none, is no matter.
  std::ofstream(dir_ / "fake-python") << "#!/bin/sh\necho \"ModuleNotFoundError: No module named 'matplotlib'\" >&2\nexit 1\n";
  fs::permissions(dir_ / "fake-python", fs::perms::owner_all);
  for (const char* env : {"TALUS_PYTHON=./fake-python", "TALUS_PYTHON=/nonexistent/python3"}) {
    const Outcome o = run({"whole.h5", "-o", "out-nompl", "--set", "bootstrap_resamples=0"}, env);
    EXPECT_EQ(o.code, 0) << o.err;
    EXPECT_TRUE(fs::exists(dir_ / "out-nompl" / "plots" / "cdf-runout.png"));
  }
  // Plots switched off: no plots folder.
  const Outcome o = run({"whole.h5", "-o", "out-noplots", "--set", "plots=false", "--set", "bootstrap_resamples=0"});
  EXPECT_EQ(o.code, 0) << o.err;
  EXPECT_FALSE(fs::exists(dir_ / "out-noplots" / "plots"));
}

// A vector file's layer, opened with OGR; closes the file when it goes.
class OgrLayer {
 public:
  OgrLayer(const fs::path& path, const std::string& layer) {
    GDALAllRegister();
    ds_ = GDALOpenEx(path.string().c_str(), GDAL_OF_VECTOR, nullptr, nullptr, nullptr);
    if (ds_) layer_ = layer.empty() ? GDALDatasetGetLayer(ds_, 0) : GDALDatasetGetLayerByName(ds_, layer.c_str());
  }
  ~OgrLayer() {
    if (ds_) GDALClose(ds_);
  }
  OgrLayer(const OgrLayer&) = delete;
  OgrLayer& operator=(const OgrLayer&) = delete;
  OGRLayerH get() const { return layer_; }
  // Every feature: its field values by name and its geometry's vertices.
  struct Feature {
    std::map<std::string, std::string> text;
    std::map<std::string, double> real;
    std::vector<std::array<double, 3>> vertices;
  };
  std::vector<Feature> features() const {
    std::vector<Feature> out;
    OGR_L_ResetReading(layer_);
    while (OGRFeatureH f = OGR_L_GetNextFeature(layer_)) {
      Feature& x = out.emplace_back();
      for (int k = 0; k < OGR_F_GetFieldCount(f); ++k) {
        const std::string name = OGR_Fld_GetNameRef(OGR_F_GetFieldDefnRef(f, k));
        x.text[name] = OGR_F_IsFieldSetAndNotNull(f, k) ? OGR_F_GetFieldAsString(f, k) : "null";
        x.real[name] = OGR_F_IsFieldSetAndNotNull(f, k) ? OGR_F_GetFieldAsDouble(f, k) : std::nan("");
      }
      if (OGRGeometryH g = OGR_F_GetGeometryRef(f))
        for (int k = 0; k < OGR_G_GetPointCount(g); ++k)
          x.vertices.push_back({OGR_G_GetX(g, k), OGR_G_GetY(g, k), OGR_G_GetZ(g, k)});
      OGR_F_Destroy(f);
    }
    return out;
  }

 private:
  GDALDatasetH ds_ = nullptr;
  OGRLayerH layer_ = nullptr;
};

// Every layer carries the terrain's CRS.
void expect_terrain_crs(const OgrLayer& layer, const std::string& what) {
  OGRSpatialReferenceH srs = OGR_L_GetSpatialRef(layer.get());
  ASSERT_NE(srs, nullptr) << what;
  OGRSpatialReferenceH expected = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(expected, 32632);
  EXPECT_TRUE(OSRIsSame(srs, expected)) << what;
  OSRDestroySpatialReference(expected);
}

TEST_F(Stats, VectorLayersInTerrainCoordinatesWithTheTerrainsCrs) {
  const Outcome o = run_fast({"whole.h5", "-o", "out-vector"});
  ASSERT_EQ(o.code, 0) << o.err;
  const fs::path gpkg = dir_ / "out-vector" / "vector" / "whole.gpkg";
  ASSERT_TRUE(fs::exists(gpkg));
  const io::RunFile run = io::read_run_file((dir_ / "whole.h5").string());
  const char* const blocks[] = {"cube", "octahedron"};
  const char* const classes[] = {"bench 1", "slope", "run-out", "other", "out of domain"};

  // Stop points: one per realization (failed ones too), at the final centroid + shift,
  // exactly; the record's values as attributes.
  const OgrLayer stops(gpkg, "stop_points");
  ASSERT_NE(stops.get(), nullptr);
  expect_terrain_crs(stops, "stop_points");
  const auto points = stops.features();
  ASSERT_EQ(points.size(), kRealizations);
  for (std::uint32_t i = 0; i < kRealizations; ++i) {
    const mc::Record& r = run.data.records[i];
    const auto& f = points[i];
    EXPECT_EQ(f.real.at("realization"), i);
    ASSERT_EQ(f.vertices.size(), 1u);
    EXPECT_EQ(f.vertices[0][0], r.final_position.x() + kShift.x()) << i;
    EXPECT_EQ(f.vertices[0][1], r.final_position.y() + kShift.y()) << i;
    EXPECT_EQ(f.vertices[0][2], r.final_position.z() + kShift.z()) << i;
    EXPECT_EQ(f.text.at("block"), blocks[i % 2]);
    EXPECT_EQ(f.text.at("end_reason"), dda::to_string(end_of(i)));
    EXPECT_EQ(f.text.at("stop_class"), classes[i % 5]);
    EXPECT_EQ(f.real.at("runout"), r.runout);
    EXPECT_EQ(f.real.at("lateral"), r.lateral);
    EXPECT_EQ(f.real.at("max_speed"), r.max_speed);
    EXPECT_EQ(f.real.at("max_jump_height"), r.max_jump_height);
    EXPECT_EQ(f.real.at("max_kinetic_energy"), r.max_kinetic_energy);
  }

  // Barrier crossings: the first crossing of the toe by each even realization, on the
  // line 10 m from its first vertex (36, 0) in the run's frame.
  const OgrLayer crossings(gpkg, "barrier_crossings");
  ASSERT_NE(crossings.get(), nullptr);
  expect_terrain_crs(crossings, "barrier_crossings");
  const auto hits = crossings.features();
  ASSERT_EQ(hits.size(), kRealizations / 2);
  for (std::size_t k = 0; k < hits.size(); ++k) {
    const auto i = static_cast<std::uint32_t>(2 * k);
    const auto& f = hits[k];
    EXPECT_EQ(f.real.at("realization"), i);
    EXPECT_EQ(f.text.at("barrier"), "toe");
    EXPECT_EQ(f.text.at("block"), "cube");
    EXPECT_EQ(f.real.at("passing_height"), 0.2 * (i + 1));  // not the second crossing's 99 m
    EXPECT_EQ(f.real.at("kinetic_energy"), 500.0 * (i + 1));
    EXPECT_EQ(f.real.at("speed"), 0.0);
    EXPECT_EQ(f.real.at("time"), 3.0);
    ASSERT_EQ(f.vertices.size(), 1u);
    EXPECT_EQ(f.vertices[0][0], 36.0 + kShift.x());
    EXPECT_EQ(f.vertices[0][1], 10.0 + kShift.y());
  }

  // Trajectories: a 3-D line of the three samples of each realization.
  const OgrLayer paths(gpkg, "trajectories");
  ASSERT_NE(paths.get(), nullptr);
  expect_terrain_crs(paths, "trajectories");
  const auto lines = paths.features();
  ASSERT_EQ(lines.size(), kRealizations);
  for (std::uint32_t i = 0; i < kRealizations; ++i) {
    ASSERT_EQ(lines[i].vertices.size(), 3u);
    EXPECT_EQ(lines[i].text.at("end_reason"), dda::to_string(end_of(i)));
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(lines[i].vertices[k][0], 1.0 + k * 5.0 + kShift.x());
      EXPECT_EQ(lines[i].vertices[k][1], 10.0 + kShift.y());
      EXPECT_EQ(lines[i].vertices[k][2], 30.0 - k * 5.0 + kShift.z());
    }
  }

  // GeoJSON: one file per layer, the same coordinates to the last bit.
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-vector", "--set", "vector_format=geojson"}).code, 0);
  EXPECT_FALSE(fs::exists(gpkg));  // this run's outputs only
  for (const char* layer : {"stop_points", "barrier_crossings", "barriers", "trajectories"}) {
    const OgrLayer json(dir_ / "out-vector" / "vector" / ("whole-" + std::string(layer) + ".geojson"), "");
    ASSERT_NE(json.get(), nullptr) << layer;
    expect_terrain_crs(json, layer);
  }
  const auto json_points = OgrLayer(dir_ / "out-vector" / "vector" / "whole-stop_points.geojson", "").features();
  ASSERT_EQ(json_points.size(), points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    EXPECT_EQ(json_points[k].vertices, points[k].vertices) << k;
    EXPECT_EQ(json_points[k].real.at("max_kinetic_energy"), points[k].real.at("max_kinetic_energy")) << k;
  }
  ASSERT_EQ(run_fast({"whole.h5", "-o", "out-vector", "--set", "vector_format=none"}).code, 0);
  EXPECT_FALSE(fs::exists(dir_ / "out-vector" / "vector" / "whole-stop_points.geojson"));
}

// A run whose toe line is digitised from `from` to `to` (x = 36, across the slope that
// falls towards +x), with a polygon release zone; the blocks cross it moving +x, but for
// realization 2, which crosses it moving back up (−x). The recorded direction is +1 from
// the line's right to its left, as dda-run writes it.
void write_fence_run(const fs::path& path, std::array<double, 2> from, std::array<double, 2> to) {
  io::RunInfo info = run_info("0/1");
  info.barrier_lines = {{from, to}};
  info.release_kind = "polygon";
  info.release = {{{{{{2.0, 8.0}, {6.0, 8.0}, {6.0, 12.0}, {2.0, 12.0}}}}, 0.75},
                  {{{{{2.0, 14.0}, {4.0, 14.0}, {4.0, 16.0}}}}, 0.25}};
  mc::RunData data;
  data.hazard = mc::HazardAccumulator(info.hazard, info.hazard_relative_accuracy);
  // Moving +x across a line digitised towards +y is moving from its left to its right.
  const int plus_x = to[1] > from[1] ? -1 : 1;
  for (std::uint32_t i = 0; i < kRealizations; ++i) {
    mc::RealizationResult r = realization(i);
    for (auto& c : r.crossings) c.direction = i == 2 ? -plus_x : plus_x;
    data.add(std::move(r));
  }
  data.sort("test");
  io::write_run_file(path.string(), info, data);
}

TEST_F(Stats, CrossingDirectionIsDownslopeWhicheverWayTheLineWasDigitised) {
  write_fence_run(dir_ / "north.h5", {36.0, 0.0}, {36.0, 20.0});
  write_fence_run(dir_ / "south.h5", {36.0, 20.0}, {36.0, 0.0});
  const Outcome o = run_fast({"north.h5", "south.h5", "-o", "out-fence"});
  ASSERT_EQ(o.code, 0) << o.err;
  for (const char* name : {"north", "south"}) {
    const fs::path gpkg = dir_ / "out-fence" / "vector" / (std::string(name) + ".gpkg");
    const auto hits = OgrLayer(gpkg, "barrier_crossings").features();
    ASSERT_EQ(hits.size(), kRealizations / 2) << name;
    for (const auto& f : hits)
      EXPECT_EQ(f.real.at("direction"), f.real.at("realization") == 2 ? -1.0 : 1.0) << name;

    // The line as the run had it, the side it faces downslope (+x) and its crossings.
    const OgrLayer barriers(gpkg, "barriers");
    ASSERT_NE(barriers.get(), nullptr) << name;
    expect_terrain_crs(barriers, "barriers");
    EXPECT_EQ(wkbFlatten(OGR_L_GetGeomType(barriers.get())), wkbLineString);
    const auto lines = barriers.features();
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_EQ(lines[0].text.at("barrier"), "toe");
    EXPECT_EQ(lines[0].real.at("length"), 20.0);
    EXPECT_EQ(lines[0].real.at("crossings"), 6.0);
    EXPECT_EQ(lines[0].text.at("downslope_side"), std::string(name) == "north" ? "right" : "left");
    ASSERT_EQ(lines[0].vertices.size(), 2u);
    EXPECT_EQ(lines[0].vertices[0][0], 36.0 + kShift.x());
    EXPECT_EQ(lines[0].vertices[0][1], (std::string(name) == "north" ? 0.0 : 20.0) + kShift.y());

    // The release zone: two polygons with their probabilities, in terrain coordinates.
    const OgrLayer release(gpkg, "release");
    ASSERT_NE(release.get(), nullptr) << name;
    expect_terrain_crs(release, "release");
    EXPECT_EQ(wkbFlatten(OGR_L_GetGeomType(release.get())), wkbMultiPolygon);
    const auto zones = release.features();
    ASSERT_EQ(zones.size(), 2u);
    EXPECT_EQ(zones[0].real.at("probability"), 0.75);
    EXPECT_EQ(zones[1].real.at("feature"), 2.0);
    OGR_L_ResetReading(release.get());
    OGRFeatureH f = OGR_L_GetNextFeature(release.get());
    ASSERT_NE(f, nullptr);
    OGREnvelope box;
    OGR_G_GetEnvelope(OGR_F_GetGeometryRef(f), &box);
    EXPECT_EQ(box.MinX, 2.0 + kShift.x());
    EXPECT_EQ(box.MaxY, 12.0 + kShift.y());
    EXPECT_EQ(OGR_G_Area(OGR_F_GetGeometryRef(f)), 16.0);
    OGR_F_Destroy(f);
  }
}

TEST_F(Stats, BadInputsGiveOneLineErrors) {
  expect_one_line_error(run_fast({"missing.h5", "-o", "out-bad"}), 3, "missing.h5");
  expect_one_line_error(run_fast({"corrupt.h5", "-o", "out-bad"}), 3, "corrupt.h5");
  expect_one_line_error(run_fast({"empty.h5", "-o", "out-bad"}), 3, "empty.h5: run file holds no realizations");
  expect_one_line_error(run_fast({"part-0.h5", "foreign-1.h5", "-o", "out-bad"}), 3,
                        "part-0.h5: the shards given hold 4 of 12 realizations; foreign-1.h5 is a shard of another run");
  expect_one_line_error(run_fast({"part-0.h5", "part-2.h5", "-o", "out-bad"}), 3, "(a shard is missing)");
  expect_one_line_error(run_fast({"part-0.h5", "part-0.h5", "-o", "out-bad"}), 3, "appears twice");
  expect_one_line_error(run_fast({"whole.h5", "whole.h5", "-o", "out-bad"}), 3, "two runs are named 'whole'");
  expect_one_line_error(run_fast({"whole.h5", "-o", "out-bad", "--set", "quantiles=[0.5, 1.5]"}), 3, "quantiles");
  expect_one_line_error(run_fast({"whole.h5", "-o", "out-bad", "--set", "names=[a, b]"}), 3, "2 names for 1 runs");
  expect_one_line_error(run_fast({"whole.h5", "-o", "out-bad", "--set", "terrain=nowhere.h5"}), 3,
                        "terrain file 'nowhere.h5'");
  // Vector layers need the terrain's CRS and origin shift as much as the rasters.
  expect_one_line_error(
      run_fast({"whole.h5", "-o", "out-bad", "--set", "terrain=nowhere.h5", "--set", "hazard_maps=false"}), 3,
      "terrain file 'nowhere.h5' is missing: give it with --set terrain=FILE (or --set vector_format=none)");
  expect_one_line_error(run_fast({"whole.h5", "-o", "corrupt.h5"}), 2, "not a directory");
  expect_one_line_error(run_fast({"whole.h5"}), 2, "-o");
  EXPECT_FALSE(fs::exists(dir_ / "out-bad"));
  const Outcome partial = run_fast({"part-0.h5", "part-2.h5", "-o", "out-partial", "--set", "allow_partial=true"});
  EXPECT_EQ(partial.code, 0) << partial.err;
  EXPECT_NE(partial.err.find("warning: run 'part': the shards given hold 8 of 12"), std::string::npos) << partial.err;
  // Without the terrain the statistics still come out when rasters and vector layers are
  // not asked for.
  EXPECT_EQ(run_fast({"whole.h5", "-o", "out-noterrain", "--set", "terrain=nowhere.h5", "--set", "hazard_maps=false",
                      "--set", "vector_format=none"})
                .code,
            0);
  EXPECT_FALSE(fs::exists(dir_ / "out-noterrain" / "vector"));
}

}  // namespace
}  // namespace talus
