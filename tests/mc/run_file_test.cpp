// The run file and the journal of a run in progress: round trip, torn appends, refusal
// of foreign journals and files.
#include "talus/io/run_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>

#include "mc_fixtures.hpp"
#include "run_compare.hpp"
#include "talus/core/error.hpp"
#include "talus/io/hdf5.hpp"
#include "talus/mc/runner.hpp"

namespace talus::io {
namespace {

namespace fs = std::filesystem;

class RunFileTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mc::SceneSettings s = mc::testing::bench_scene(4);
    s.engine.trajectory_interval = 0.2;
    scene_ = new mc::Scene(mc::Scene::build(s, mc::testing::bench_terrain(), mc::testing::library({block::SolidKind::cube}), "t"));
    results_ = new std::vector<mc::RealizationResult>();
    mc::run_realizations(*scene_, {0, 1, 2, 3}, 2, [](mc::RealizationResult&& r) { results_->push_back(std::move(r)); });
    std::sort(results_->begin(), results_->end(),
              [](const auto& a, const auto& b) { return a.record.realization < b.record.realization; });
  }
  static void TearDownTestSuite() {
    delete results_;
    delete scene_;
  }
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("talus_run_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static RunInfo info(std::uint64_t seed = 11) {
    Provenance p;
    p.tool = "test";
    p.settings_yaml = "seed: " + std::to_string(seed) + "\n";
    return make_run_info(*scene_, p, mc::Shard{});
  }
  // The whole run as one RunData (the reference).
  static mc::RunData reference() {
    mc::RunData d;
    d.hazard = mc::HazardAccumulator(scene_->hazard_grid(), 0.01);
    for (const auto& r : *results_) d.add(mc::RealizationResult(r));
    d.sort("reference");
    return d;
  }
  static mc::Scene* scene_;
  static std::vector<mc::RealizationResult>* results_;
  fs::path dir_;
};
mc::Scene* RunFileTest::scene_ = nullptr;
std::vector<mc::RealizationResult>* RunFileTest::results_ = nullptr;

TEST_F(RunFileTest, RoundTripsEveryTable) {
  const mc::RunData ref = reference();
  ASSERT_FALSE(ref.trajectories.empty());
  const std::string path = (dir_ / "run.h5").string();
  write_run_file(path, info(), ref);
  const RunFile f = read_run_file(path);
  mc::testing::expect_same_run(ref, f.data);
  EXPECT_EQ(f.info.shard, "0/1");
  EXPECT_EQ(f.info.barriers, (std::vector<std::string>{"lower slope", "toe"}));
  EXPECT_EQ(f.info.barrier_lines[1][1][1], 20.0);
  EXPECT_EQ(f.info.hazard.nx, scene_->hazard_grid().nx);
  // The release zone as drawn from: bench_scene's one point, probability 1.
  EXPECT_EQ(f.info.release_kind, "point");
  ASSERT_EQ(f.info.release.size(), 1u);
  EXPECT_EQ(f.info.release[0].probability, 1.0);
  ASSERT_EQ(f.info.release[0].parts.size(), 1u);
  EXPECT_EQ(f.info.release[0].parts[0], (std::vector<std::vector<std::array<double, 2>>>{{{26.0, 10.0}}}));
  EXPECT_TRUE(fs::exists(dir_ / "run.xmf"));
  // Not a run file: a journal, and a file of another kind.
  RunJournal::create((dir_ / "j.journal").string(), info());
  EXPECT_THROW(read_run_file((dir_ / "j.journal").string()), core::InputError);
  EXPECT_THROW(read_run_file((dir_ / "j.journal" / "info.h5").string()), core::InputError);
}

TEST_F(RunFileTest, ReaderRefusesNonFiniteValuesOfRealizationsThatDidNotFail) {
  mc::RunData data = reference();
  const std::uint32_t which = data.records[1].realization;
  data.records[1].end = dda::EndReason::rest;
  data.records[1].runout = std::numeric_limits<double>::quiet_NaN();
  const std::string path = (dir_ / "nan.h5").string();
  write_run_file(path, info(), data);
  try {
    read_run_file(path);
    FAIL() << "a NaN runout was accepted";
  } catch (const core::InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": /records: realization " + std::to_string(which) +
                                         ": runout is nan (values of a realization that did not fail must be finite)");
  }
  // A numerically failed realization may carry non-finite values: it is counted, not used.
  data.records[1].end = dda::EndReason::non_finite;
  write_run_file(path, info(), data);
  EXPECT_NO_THROW(read_run_file(path));
}

TEST_F(RunFileTest, ReaderRefusesNonPhysicalValuesAndCounts) {
  mc::RunData data = reference();
  data.records[1].end = dda::EndReason::rest;
  data.records[1].max_kinetic_energy = -1e9;
  const std::string path = (dir_ / "negative.h5").string();
  write_run_file(path, info(), data);
  try {
    read_run_file(path);
    FAIL() << "a negative kinetic energy was accepted";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("max_kinetic_energy is -1000000000 (must be >= 0)"), std::string::npos) << e.what();
  }
  RunInfo bad = info();
  bad.shard = "7/3";
  write_run_file(path, bad, reference());
  EXPECT_THROW(read_run_file(path), core::InputError);
  bad = info();
  bad.realizations = 1000000000000000ULL;
  write_run_file(path, bad, reference());
  EXPECT_THROW(read_run_file(path), core::InputError);
}

TEST_F(RunFileTest, TornAppendIsDroppedOnResume) {
  const std::string path = (dir_ / "run.h5.journal").string();
  {
    RunJournal j = RunJournal::create(path, info());
    j.append({(*results_)[2], (*results_)[0]});  // completion order, not index order
  }
  // A run killed in the middle of its next chunk: a half-written temporary chunk file.
  const fs::path torn = fs::path(path) / ".chunk-00000001.h5.tmp-999999";
  std::ofstream(torn) << "\x89HDF\r\n half a chunk";
  RunJournal j = RunJournal::resume(path, info());
  EXPECT_FALSE(fs::exists(torn));
  EXPECT_EQ(j.finished(), (std::vector<std::uint32_t>{0, 2}));
  j.append({(*results_)[3], (*results_)[1]});
  mc::testing::expect_same_run(reference(), j.read());
  // Another run's settings or shard: refused.
  EXPECT_THROW(RunJournal::resume(path, info(12)), core::InputError);
  RunInfo other_shard = info();
  other_shard.shard = "1/2";
  EXPECT_THROW(RunJournal::resume(path, other_shard), core::InputError);
  EXPECT_THROW(RunJournal::resume((dir_ / "none").string(), info()), core::InputError);
  // Killed while creating the journal, before its metadata was written: resumed as empty.
  const fs::path bare = dir_ / "bare.journal";
  fs::create_directory(bare);
  EXPECT_TRUE(RunJournal::resume(bare.string(), info()).finished().empty());
  // A chunk file repeating a realization of another: refused, naming the file.
  {
    RunJournal twice = RunJournal::create((dir_ / "twice.journal").string(), info());
    twice.append({(*results_)[0]});
    twice.append({(*results_)[0]});
  }
  EXPECT_THROW(RunJournal::resume((dir_ / "twice.journal").string(), info()), core::InputError);
}

TEST_F(RunFileTest, MergeChecksTheShardsBelongTogether) {
  mc::RunData even, odd;
  even.hazard = odd.hazard = mc::HazardAccumulator(scene_->hazard_grid(), 0.01);
  for (const auto& r : *results_) (r.record.realization % 2 ? odd : even).add(mc::RealizationResult(r));
  RunFile a{info(), even}, b{info(), odd}, c{info(12), odd};
  a.info.shard = "0/2";
  b.info.shard = "1/2";
  const RunFile merged = merge_run_files({b, a}, {"b.h5", "a.h5"});
  EXPECT_EQ(merged.info.shard, "0/1");
  mc::testing::expect_same_run(reference(), merged.data);
  EXPECT_EQ(merge_run_files({a}, {"a.h5"}).info.shard, "partial");
  try {
    merge_run_files({a, c}, {"a.h5", "c.h5"});
    FAIL() << "a shard of another run was merged";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("c.h5: is not a shard of the same run"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace talus::io
