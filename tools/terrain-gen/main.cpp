// terrain-gen: builds a terrain file (TRN or TIN, materials, roughness model) from a DEM,
// surveyed meshes, a point cloud or a synthetic slope. See docs/terrain.md.
#include <charconv>
#include <cstdio>
#include <string>

#include "build_terrain.hpp"
#include "settings.hpp"
#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/core/timer.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/mesh_io.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/terrain_file.hpp"
#include "talus/io/xdmf.hpp"
#include "talus/terrain/material_classes.hpp"

namespace {

using namespace talus;

std::optional<std::uint32_t> parse_realization(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::uint32_t value = 0;
  const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (err != std::errc() || end != text.data() + text.size())
    throw core::UsageError("--realization expects a non-negative integer, got '" + text + "'");
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  terrain_gen::Settings settings;
  bool print_summary = false;
  bool list_classes = false;
  std::string export_path;
  std::string realization_text;

  cli::ToolSpec spec;
  spec.name = "terrain-gen";
  spec.summary = "Build a terrain file (TRN/TIN, materials, roughness) from a DEM, meshes, points or a synthetic slope";
  spec.inputs_doc =
      "DEM (.asc, .tif), meshes (.stl .obj .ply .off .gltf; one file per material), or point clouds "
      "(.xyz .txt .pts .csv, with or without a header line naming X, Y, Z; uncompressed LAS .las; .ply without "
      "faces); none for a synthetic slope; or a terrain file (.h5) to inspect with --summary / --export-mesh";
  spec.set_example = "roughness.sigma=0.2";
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.flags = {{"--summary", "print a summary of the built terrain (kind, sizes, extent, materials, roughness)",
                 &print_summary},
                {"--list-material-classes",
                 "print the built-in ground-material classes (materials[].class) with their parameters and sources",
                 &list_classes}};
  spec.options = {
      {"--export-mesh", "also write a realization of the surface as a mesh (.obj or .ply with material per face)",
       &export_path, "FILE"},
      {"--realization", "realization exported by --export-mesh (default: the smooth base)", &realization_text, "N"}};

  spec.check = [&](const cli::Invocation& inv) {
    if (list_classes) {
      if (!inv.output.empty() || !inv.inputs.empty() || print_summary || !export_path.empty())
        throw core::UsageError("--list-material-classes takes no inputs, outputs or other flags");
      return;
    }
    if (inv.output.empty() && !print_summary && export_path.empty())
      throw core::UsageError("no output file given (-o FILE; or --summary / --export-mesh alone)");
    if (!realization_text.empty() && export_path.empty())
      throw core::UsageError("--realization needs --export-mesh");
    parse_realization(realization_text);
    if (!export_path.empty()) {
      const std::string ext = io::lower_extension(export_path);
      if (ext != ".obj" && ext != ".ply")
        throw core::UsageError("--export-mesh writes .obj or .ply, got '" + export_path + "'");
      io::AtomicOutput probe(export_path);  // fails now if its directory is missing
    }
    if (!inv.output.empty()) {
      if (io::lower_extension(inv.output) == ".xmf")
        throw core::UsageError("the output is the HDF5 terrain file; its .xmf sidecar is written next to it");
      io::AtomicOutput probe(inv.output);
    }
    if (terrain_gen::resolve_source(settings, inv.inputs) == terrain_gen::SourceKind::file && !inv.output.empty()) {
      io::check_terrain_file(inv.inputs.front());  // a block or run file is named as such first
      throw core::UsageError("a terrain file input is only inspected (--summary, --export-mesh); drop -o");
    }
    std::vector<io::NamedPath> inputs = inv.named_inputs();
    if (!settings.material_raster.empty()) inputs.push_back({"material_raster", settings.material_raster});
    if (!settings.zone_file.file.empty()) inputs.push_back({"zone_file.file", settings.zone_file.file});
    io::check_outputs_distinct(
        inputs, {{"-o", inv.output},
                 {"XDMF sidecar of -o", inv.output.empty() ? "" : io::xdmf_sidecar_path(inv.output)},
                 {"--export-mesh", export_path}});
  };

  spec.run = [&](const cli::Invocation& inv) {
    if (list_classes) {
      std::fputs(terrain::material_classes_table().c_str(), stdout);
      return;
    }
    core::Stopwatch clock;
    const terrain_gen::Built built = terrain_gen::build_terrain(settings, inv.inputs, inv.origins);
    const terrain::Terrain& t = built.terrain;
    const bool read_back = built.kind == terrain_gen::SourceKind::file;
    core::log_info((read_back ? "read " : "built ") + std::string(t.grid ? "grid TRN" : "TIN") + " '" + t.name + "': " +
                   std::to_string(t.mesh.vertices.size()) + " points, " + std::to_string(t.mesh.triangles.size()) +
                   " triangles in " + core::format_number(clock.seconds()) + " s");
    clock.restart();
    if (!export_path.empty()) {
      const auto realization = parse_realization(realization_text);
      const terrain::Surface surface = terrain::Surface::realize(t, realization);
      std::vector<std::int32_t> material(surface.triangle_count());
      for (std::size_t k = 0; k < material.size(); ++k) material[k] = surface.material(k);
      io::export_mesh(export_path, surface.to_mesh(), material);
    }
    if (!inv.output.empty()) {
      io::write_terrain_file(inv.output, t, inv.provenance("terrain-gen", settings.seed), built.roughness_index,
                             io::xdmf_sidecar_path(inv.output));
    }
    if (!inv.output.empty() || !export_path.empty())
      core::log_info("wrote the outputs in " + core::format_number(clock.seconds()) + " s");
    if (print_summary) std::fputs(terrain_gen::summary(built).c_str(), stdout);
  };
  return cli::run_tool(argc, argv, spec);
}
