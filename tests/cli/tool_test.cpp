#include "talus/cli/tool.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "../support/temp_path.hpp"

namespace talus::cli {
namespace {

struct Settings {
  double sigma = 0.2;
  std::string mode = "alternating";
  void visit(core::SettingsVisitor& v) {
    v.field("sigma", sigma, "m", "roughness");
    v.choice("mode", mode, {"fixed", "alternating"}, "diagonal");
  }
};

// Runs a tool whose run() does `action`, with the given arguments; returns the exit code
// and stderr.
struct Result {
  int code;
  std::string err;
  std::string out;
};
Result run(const std::vector<std::string>& args, std::function<void(const Invocation&)> action = {},
           Settings* settings_out = nullptr) {
  Settings settings;
  ToolSpec spec;
  spec.name = "demo-tool";
  spec.summary = "demo";
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.run = action ? action : [](const Invocation&) {};
  std::vector<std::string> storage{"demo-tool"};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : storage) argv.push_back(s.data());
  ::testing::internal::CaptureStderr();
  ::testing::internal::CaptureStdout();
  const int code = run_tool(static_cast<int>(argv.size()), argv.data(), spec);
  Result r{code, ::testing::internal::GetCapturedStderr(), ::testing::internal::GetCapturedStdout()};
  if (settings_out) *settings_out = settings;
  return r;
}

std::string temp_file(const std::string& name) {
  return talus::testing::temp_path("cli_test", name);
}

TEST(RunTool, HelpAndVersionSucceed) {
  EXPECT_EQ(run({"--help"}).code, 0);
  const Result v = run({"--version"});
  EXPECT_EQ(v.code, 0);
  EXPECT_NE(v.out.find("demo-tool (Talus)"), std::string::npos);
}

TEST(RunTool, UsageErrorsExitTwoWithOneLine) {
  const Result unknown = run({"--no-such-flag", "-o", "x"});
  EXPECT_EQ(unknown.code, 2);
  EXPECT_EQ(unknown.err.rfind("demo-tool: error: ", 0), 0u) << unknown.err;
  EXPECT_EQ(std::count(unknown.err.begin(), unknown.err.end(), '\n'), 1);
  const Result no_output = run({});
  EXPECT_EQ(no_output.code, 2);
  EXPECT_EQ(no_output.err, "demo-tool: error: no output file given (-o FILE)\n");
  EXPECT_EQ(run({"--set", "sigma", "-o", "x"}).code, 2);
  EXPECT_EQ(run({"--log-level", "loud", "-o", "x"}).code, 2);
}

TEST(RunTool, SettingsFromFileAndOverrides) {
  const std::string path = temp_file("settings.yaml");
  io::write_text_file(path, "sigma: 0.4\n");
  Settings s;
  const Result r = run({"-c", path, "--set", "mode=fixed", "-o", "out"}, {}, &s);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(s.sigma, 0.4);
  EXPECT_EQ(s.mode, "fixed");
  std::filesystem::remove(path);
}

TEST(RunTool, BadSettingsExitThreeNamingFileAndKey) {
  const std::string path = temp_file("bad.yaml");
  io::write_text_file(path, "sigma: 0.4\nsigam: 1\n");
  const Result r = run({"-c", path, "-o", "out"});
  EXPECT_EQ(r.code, 3);
  EXPECT_EQ(r.err, "demo-tool: error: " + path + ":2: unknown key 'sigam' (did you mean 'sigma'?)\n");
  EXPECT_EQ(run({"-c", temp_file("missing.yaml"), "-o", "out"}).code, 3);
  EXPECT_EQ(run({"--set", "mode=diagonal", "-o", "out"}).code, 3);
  std::filesystem::remove(path);
}

TEST(RunTool, PrintConfigShowsDefaultsWithUnitsAndNeedsNoOutput) {
  const Result r = run({"--print-config", "--set", "sigma=0.3"});
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("sigma: 0.3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[m] roughness"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mode: alternating"), std::string::npos) << r.out;
}

TEST(RunTool, FailuresInRunMapToExitCodes) {
  EXPECT_EQ(run({"-o", "x"}, [](const Invocation&) { throw core::InputError("in.asc", "bad header"); }).code, 3);
  const Result runtime = run({"-o", "x"}, [](const Invocation&) { throw core::RuntimeError("disk full"); });
  EXPECT_EQ(runtime.code, 1);
  EXPECT_EQ(runtime.err, "demo-tool: error: disk full\n");
  const Result internal = run({"-o", "x"}, [](const Invocation&) { throw std::logic_error("oops"); });
  EXPECT_EQ(internal.code, 1);
  EXPECT_EQ(internal.err, "demo-tool: error: internal error: oops\n");
}

TEST(RunTool, InvocationCarriesEffectiveSettingsForProvenance) {
  std::string yaml;
  const Result r = run({"--set", "sigma=0.7", "in1", "in2", "-o", "x"}, [&yaml](const Invocation& inv) {
    yaml = inv.settings_yaml;
    EXPECT_EQ(inv.inputs.size(), 2u);
    EXPECT_EQ(inv.provenance("demo-tool", 5).inputs, "in1\nin2\n");
  });
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(yaml.find("sigma: 0.7"), std::string::npos);
  EXPECT_EQ(yaml.find('#'), std::string::npos);  // no comments in the provenance copy
}

}  // namespace
}  // namespace talus::cli
