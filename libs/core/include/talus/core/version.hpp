// SPDX-License-Identifier: MIT
#pragma once
#include <string_view>

namespace talus::core {
/// The Talus release version, "MAJOR.MINOR.PATCH".
std::string_view version();
}  // namespace talus::core
