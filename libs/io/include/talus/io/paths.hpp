// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <vector>

namespace talus::io {

/// The extension of `path` with its dot, in lower case ("scan.PLY" → ".ply"; "" if none):
/// file kinds are recognised whatever the case of the name.
std::string lower_extension(const std::string& path);

}  // namespace talus::io

namespace talus::io {

/// A file a tool reads or writes, with how the user named it ("-o", "input", "-c",
/// "terrain") for messages.
struct NamedPath {
  std::string role;
  std::string path;
};

/// True when `a` and `b` name the same file however spelled: relative or absolute, with
/// "./" or "..", through a symbolic link, or (for existing files) as hard links.
bool same_file(const std::string& a, const std::string& b);

/// Refuses (core::UsageError, before any work) an output that names an input or another
/// output of the same call, so that no input is ever overwritten. Empty paths are ignored.
void check_outputs_distinct(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs);

/// True when `path` lies inside the directory `dir` (at any depth), however spelled.
bool inside_directory(const std::string& path, const std::string& dir);

/// Creates the directory `path` and its missing parents; throws core::RuntimeError naming
/// it when it cannot (a file of that name, no permission).
void make_directories(const std::string& path);

}  // namespace talus::io
