// SPDX-License-Identifier: MIT
#pragma once
#include <string>

namespace talus::io {

/// The extension of `path` with its dot, in lower case ("scan.PLY" → ".ply"; "" if none):
/// file kinds are recognised whatever the case of the name.
std::string lower_extension(const std::string& path);

}  // namespace talus::io
