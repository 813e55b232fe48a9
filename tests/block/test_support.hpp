// SPDX-License-Identifier: MIT
// Helpers shared by the block tests: scratch files, rigid motions, mesh writers.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "talus/block/solids.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/geometry/polyhedron.hpp"
#include "talus/geometry/triangle_mesh.hpp"

namespace talus::block::test {

namespace fs = std::filesystem;

/// A scratch directory per test (ctest runs tests in parallel), removed afterwards.
class ScratchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("talus_block_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// OBJ text of a triangle mesh with full double precision.
inline std::string obj_text(const geometry::TriangleMesh& mesh) {
  std::string s;
  char line[128];
  for (const auto& p : mesh.vertices) {
    std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x(), p.y(), p.z());
    s += line;
  }
  for (const auto& t : mesh.triangles) {
    std::snprintf(line, sizeof line, "f %d %d %d\n", t[0] + 1, t[1] + 1, t[2] + 1);
    s += line;
  }
  return s;
}

/// The same mesh as OFF, ASCII PLY or ASCII STL text, full double precision.
inline std::string mesh_text(const geometry::TriangleMesh& mesh, const std::string& format) {
  if (format == "obj") return obj_text(mesh);
  std::string s;
  char line[160];
  auto point = [&](const geometry::Vec3& p, const char* prefix) {
    std::snprintf(line, sizeof line, "%s%.17g %.17g %.17g\n", prefix, p.x(), p.y(), p.z());
    s += line;
  };
  if (format == "stl") {
    s = "solid test\n";
    for (const auto& t : mesh.triangles) {
      s += "facet normal 0 0 0\n outer loop\n";
      for (int k = 0; k < 3; ++k) point(mesh.vertices[t[static_cast<std::size_t>(k)]], "  vertex ");
      s += " endloop\nendfacet\n";
    }
    return s + "endsolid test\n";
  }
  if (format == "off") {
    s = "OFF\n# a test solid\n" + std::to_string(mesh.vertices.size()) + " " + std::to_string(mesh.triangles.size()) + " 0\n";
  } else {
    s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(mesh.vertices.size()) +
        "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
        std::to_string(mesh.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  }
  for (const auto& p : mesh.vertices) point(p, "");
  for (const auto& t : mesh.triangles) s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  return s;
}

/// block-gen's `ellipsoid` solid: diameters (m), geodesic frequency, roughness (−), target
/// volume (m³; ≤ 0 keeps the diameters) and seed.
inline geometry::Polyhedron rough_ellipsoid(const geometry::Vec3& diameters, int resolution, double roughness,
                                            double volume = 0.0, std::uint64_t seed = 1) {
  SolidSpec spec;
  spec.kind = SolidKind::ellipsoid;
  spec.dimensions = diameters;
  spec.resolution = resolution;
  spec.roughness = roughness;
  spec.volume = volume;
  spec.seed = seed;
  return make_solid(spec, "test");
}

/// A fixed "arbitrary" rotation (no symmetry axis of any test solid).
inline geometry::Mat3 arbitrary_rotation() {
  return Eigen::AngleAxisd(0.7341, geometry::Vec3(0.3, -0.8, 0.52).normalized()).toRotationMatrix();
}

/// The polyhedron moved by x → R x + t.
inline geometry::Polyhedron moved(geometry::Polyhedron poly, const geometry::Mat3& r, const geometry::Vec3& t) {
  for (auto& p : poly.vertices) p = r * p + t;
  return poly;
}

inline geometry::TriangleMesh as_triangles(const geometry::Polyhedron& poly) { return geometry::triangulate(poly); }

}  // namespace talus::block::test
