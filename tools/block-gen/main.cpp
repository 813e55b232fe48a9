// block-gen: rocks from meshes, point clouds and named solids, with exact properties,
// into a block file (a block library). See docs/block.md.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "generate.hpp"
#include "settings.hpp"
#include "talus/cli/tool.hpp"
#include "talus/core/error.hpp"
#include "talus/core/log.hpp"
#include "talus/geometry/half_edge.hpp"
#include "talus/io/atomic_output.hpp"
#include "talus/io/block_file.hpp"
#include "talus/io/mesh_io.hpp"
#include "talus/io/paths.hpp"
#include "talus/io/xdmf.hpp"

namespace {

using namespace talus;


// `block-gen info FILE ...` or `block-gen --info FILE`.
std::vector<std::string> info_files(const cli::Invocation& inv, const std::string& info_option) {
  std::vector<std::string> files;
  if (!info_option.empty()) files.push_back(info_option);
  if (!inv.inputs.empty() && inv.inputs.front() == "info") files.insert(files.end(), inv.inputs.begin() + 1, inv.inputs.end());
  return files;
}

bool info_mode(const cli::Invocation& inv, const std::string& info_option) {
  return !info_option.empty() || (!inv.inputs.empty() && inv.inputs.front() == "info");
}

void print_info(const std::string& path) {
  const std::vector<block::Block> blocks = io::read_block_file(path);
  double total = 0.0;
  for (const auto& b : blocks) total += b.weight;
  std::printf("%s: block library of %zu block(s)\n", path.c_str(), blocks.size());
  for (const auto& b : blocks) {
    std::fputs(io::describe_block(b).c_str(), stdout);
    std::printf("  sampling share     %.6g\n", b.weight / total);
  }
}

// The mesh files --export-mesh PATH writes: PATH itself for a single block,
// PATH_STEM_<name>.EXT per block otherwise.
std::vector<std::string> export_paths(const std::string& path, const std::vector<std::string>& names) {
  if (path.empty()) return {};
  if (names.size() <= 1) return {path};
  const std::filesystem::path p(path);
  std::vector<std::string> out;
  for (const auto& name : names)
    out.push_back((p.parent_path() / (p.stem().string() + "_" + name + p.extension().string())).string());
  return out;
}

// The block names build_blocks will give, known before any block is built.
std::vector<std::string> block_names(const block_gen::Settings& settings, const std::vector<std::string>& inputs) {
  std::vector<std::string> names;
  for (const auto& b : settings.blocks) {
    if (!b.name.empty()) names.push_back(b.name);
    else if (b.solid != "none") names.push_back(b.solid);
    else names.push_back(std::filesystem::path(b.mesh.empty() ? b.cloud : b.mesh).stem().string());
  }
  for (const auto& input : inputs) names.push_back(std::filesystem::path(input).stem().string());
  return names;
}

void export_meshes(const std::string& path, const std::vector<block::Block>& blocks) {
  std::vector<std::string> names;
  for (const auto& b : blocks) names.push_back(b.name);
  const std::vector<std::string> targets = export_paths(path, names);
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const block::Block& b = blocks[k];
    geometry::TriangleMesh mesh = geometry::triangulate(b.polyhedron);
    for (auto& v : mesh.vertices) v = b.rotation * v + b.translation;
    io::export_mesh(targets[k], mesh);
  }
}

}  // namespace

int main(int argc, char** argv) {
  block_gen::Settings settings;
  std::string info_option;
  std::string export_path;

  cli::ToolSpec spec;
  spec.name = "block-gen";
  spec.summary = "Build a block library (validated polyhedra with exact properties) from meshes, point clouds "
                 "and named solids; 'block-gen info FILE' prints a block file";
  spec.inputs_doc = "mesh files (.obj .stl .ply .off .gltf ...) or point clouds (.xyz .txt .pts .csv, LAS .las, PLY "
                    "without faces), one block each; or 'info FILE.h5 ...'";
  spec.set_example = "inputs.scale=0.001";
  spec.settings = [&settings](core::SettingsVisitor& v) { settings.visit(v); };
  spec.options = {{"--info", "print the properties of every block of a block file and exit", &info_option},
                  {"--export-mesh", "also write the blocks as meshes at their input position (.obj or .ply; "
                                    "PATH_<name>.ext per block when there are several)", &export_path}};

  spec.check = [&](const cli::Invocation& inv) {
    if (info_mode(inv, info_option)) {
      if (info_files(inv, info_option).empty()) throw core::UsageError("info needs a block file (block-gen info FILE.h5)");
      return;
    }
    if (inv.output.empty()) throw core::UsageError("no output file given (-o FILE)");
    if (io::lower_extension(inv.output) == ".xmf")
      throw core::UsageError("the output is the HDF5 block file; its .xmf sidecar is written next to it");
    io::AtomicOutput probe(inv.output);  // fails now if its directory is missing
    if (!export_path.empty()) {
      const std::string ext = io::lower_extension(export_path);
      if (ext != ".obj" && ext != ".ply")
        throw core::UsageError("--export-mesh writes .obj or .ply, got '" + export_path + "'");
    }
    std::vector<io::NamedPath> inputs = inv.named_inputs();
    for (std::size_t i = 0; i < settings.blocks.size(); ++i) {
      const std::string key = "blocks[" + std::to_string(i) + "]";
      if (!settings.blocks[i].mesh.empty()) inputs.push_back({key + ".mesh", settings.blocks[i].mesh});
      if (!settings.blocks[i].cloud.empty()) inputs.push_back({key + ".cloud", settings.blocks[i].cloud});
    }
    std::vector<io::NamedPath> outputs = {{"-o", inv.output},
                                          {"XDMF sidecar of -o", settings.xdmf ? io::xdmf_sidecar_path(inv.output) : ""}};
    for (const auto& path : export_paths(export_path, block_names(settings, inv.inputs)))
      outputs.push_back({"--export-mesh", path});
    io::check_outputs_distinct(inputs, outputs);
  };

  spec.run = [&](const cli::Invocation& inv) {
    if (info_mode(inv, info_option)) {
      for (const auto& file : info_files(inv, info_option)) print_info(file);
      return;
    }
    const std::vector<block::Block> blocks = block_gen::build_blocks(settings, inv.inputs, inv.origins);
    // A scan in centimetres read as metres is a million times too large, yet may still lie
    // inside the volumes a block may have: say so for read blocks of volumes no rockfall
    // block has (a solid asked for by volume is what was asked).
    constexpr double kLargeBlock = 1e4;  // m^3
    for (const auto& b : blocks)
      if (b.volume_exact > kLargeBlock && std::find(inv.inputs.begin(), inv.inputs.end(), b.source) != inv.inputs.end())
        core::log_warn(b.source + ": block '" + b.name + "' has a volume of " + core::format_number(b.volume_exact) +
                       " m^3, more than rockfall blocks have (1e4 m^3): if the mesh is in centimetres or "
                       "millimetres, set inputs.scale to 0.01 or 0.001");
    io::write_block_file(inv.output, blocks, inv.provenance("block-gen", block_gen::provenance_seed(settings)),
                         settings.xdmf ? io::xdmf_sidecar_path(inv.output) : std::string());
    if (!export_path.empty()) export_meshes(export_path, blocks);
    for (const auto& b : blocks)
      core::log_info(b.name + ": " + std::to_string(b.polyhedron.faces.size()) + " faces, V = " +
                     core::format_number(b.volume_exact) + " m^3, psi = " + core::format_number(b.sphericity));
  };
  return cli::run_tool(argc, argv, spec);
}
