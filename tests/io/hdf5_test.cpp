#include "talus/io/hdf5.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "talus/core/error.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/file_header.hpp"
#include "../support/temp_path.hpp"

namespace talus::io {
namespace {

std::string temp_file(const std::string& name) {
  return talus::testing::temp_path("io_test", name);
}

TEST(Hdf5, RoundTripsDatasetsAndAttributes) {
  const std::string path = temp_file("roundtrip.h5");
  {
    const h5::File f = h5::File::create(path);
    const h5::Group g = f.root().create_group("grid");
    const std::vector<double> z = {1, 2, 3, 4, 5, 6};
    g.write("z", z.data(), {2, 3}, "m", true);
    const std::vector<std::int32_t> ids = {7, 8};
    g.write("ids", ids.data(), {2});
    g.write_strings("names", {"rock", "scree"});
    g.set_attr("dx", 2.0);
    g.set_attr("nx", std::int64_t{31});
    g.set_attr("label", "bench");
  }
  const h5::File f = h5::File::open(path);
  const h5::Group g = f.root().open_group("grid");
  EXPECT_EQ(g.read_doubles("z", {2, 0}), (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(g.dataset_attr_string("z", "unit"), "m");
  EXPECT_EQ(g.read_int32("ids"), (std::vector<std::int32_t>{7, 8}));
  EXPECT_EQ(g.read_strings("names"), (std::vector<std::string>{"rock", "scree"}));
  EXPECT_EQ(g.attr_double("dx"), 2.0);
  EXPECT_EQ(g.attr_int("nx"), 31);
  EXPECT_EQ(g.attr_string("label"), "bench");
  EXPECT_THROW(g.read_doubles("z", {3, 2}), core::InputError);
  EXPECT_THROW(g.read_doubles("missing"), core::InputError);
  EXPECT_THROW(f.root().open_group("nope"), core::InputError);
  std::filesystem::remove(path);
}

TEST(Hdf5, SameContentGivesIdenticalBytes) {
  auto write = [](const std::string& path) {
    const h5::File f = h5::File::create(path);
    const std::vector<double> v(1000, 1.5);
    f.root().create_group("g").write("v", v.data(), {1000}, "m", true);
  };
  const std::string a = temp_file("a.h5"), b = temp_file("b.h5");
  write(a);
  write(b);
  auto bytes = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(a), bytes(b));
  std::filesystem::remove(a);
  std::filesystem::remove(b);
}

TEST(FileHeader, ChecksKindAndMajorVersion) {
  const std::string path = temp_file("header.h5");
  {
    const h5::File f = h5::File::create(path);
    Provenance p;
    p.tool = "terrain-gen";
    p.settings_yaml = "a: 1\n";
    p.seed = 99;
    write_header(f.root(), "terrain", {1, 3}, p);
  }
  const h5::File f = h5::File::open(path);
  const SchemaVersion v = check_header(f.root(), "terrain", {1, 0});
  EXPECT_EQ(v.minor, 3);
  EXPECT_EQ(read_provenance(f.root()).seed, 99u);
  try {
    check_header(f.root(), "terrain", {2, 0});
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("schema version 1.3 is not supported"), std::string::npos);
  }
  EXPECT_THROW(check_header(f.root(), "block", {1, 0}), core::InputError);
  std::filesystem::remove(path);
}

TEST(Hdf5, MissingAndNonHdf5FilesAreInputErrors) {
  EXPECT_THROW(h5::File::open(temp_file("does-not-exist.h5")), core::InputError);
  const std::string text = temp_file("text.h5");
  write_text_file(text, "not hdf5");
  try {
    h5::File::open(text);
    FAIL();
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not an HDF5 file"), std::string::npos);
  }
  std::filesystem::remove(text);
}

TEST(AtomicOutput, UncommittedLeavesNothing) {
  const std::string path = temp_file("atomic.txt");
  std::filesystem::remove(path);
  std::string temp;
  {
    AtomicOutput out(path);
    temp = out.temp_path();
    std::ofstream(temp) << "partial";
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_FALSE(std::filesystem::exists(temp));
  write_text_file(path, "done");
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove(path);
  EXPECT_THROW(AtomicOutput("/nonexistent-dir/x.h5"), core::RuntimeError);
}

TEST(Hdf5, AppendableDatasetsGrowAcrossReopening) {
  const std::string path = temp_file("append.h5");
  {
    const h5::File f = h5::File::create(path);
    const h5::Group root = f.root();
    root.create_appendable("rows", h5::Group::Element::f64, 3, "m", 2);
    root.create_appendable("ids", h5::Group::Element::i64);
    const std::vector<double> a = {1, 2, 3, 4, 5, 6};
    root.append("rows", a.data(), 2);
    const std::vector<std::int64_t> ids = {7};
    root.append("ids", ids.data(), 1);
    EXPECT_THROW(root.append("missing", ids.data(), 1), core::RuntimeError);
    EXPECT_THROW(root.append("rows", ids.data(), 1), core::RuntimeError);  // wrong element type
  }
  {
    // A resumed journal appends after what an earlier process wrote.
    const h5::File f = h5::File::open_rw(path);
    const std::vector<double> b = {7, 8, 9};
    f.root().append("rows", b.data(), 1);
    const std::vector<std::int64_t> ids = {8, 9};
    f.root().append("ids", ids.data(), 2);
    f.root().append("ids", ids.data(), 1);
    f.root().truncate_rows("ids", 3);  // drops the last, torn append
    f.root().truncate_rows("ids", 10);  // longer than the dataset: no-op
  }
  const h5::File f = h5::File::open(path);
  EXPECT_EQ(f.root().shape("rows"), (h5::Shape{3, 3}));
  EXPECT_EQ(f.root().read_doubles("rows"), (std::vector<double>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(f.root().read_int64("ids"), (std::vector<std::int64_t>{7, 8, 9}));
  EXPECT_EQ(f.root().dataset_attr_string("rows", "unit"), "m");
  std::filesystem::remove(path);
  EXPECT_THROW(h5::File::open_rw(path), core::InputError);
}

}  // namespace
}  // namespace talus::io
