// SPDX-License-Identifier: MIT
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "talus/core/settings.hpp"

namespace talus::io {

/// The visit function of a settings struct (see core::SettingsVisitor).
using SettingsBody = std::function<void(core::SettingsVisitor&)>;

/// Effective settings from YAML text and `key.path=value` overrides, applied over the
/// defaults already in the struct. `source` names the text in messages (a file name).
/// Unknown keys, wrong types and values outside a choice throw core::InputError with the
/// source, the line and the key path; malformed overrides throw core::UsageError.
/// `origins`, when given, records where each value came from (the --set key or the
/// line), for the messages of checks made after reading; its source names the rest.
/// `given_by[k]` names where override k was given when not on the command line
/// ("calibrate.yaml:7: set"; messages then name it and the key); default "--set".
void read_settings(const std::string& yaml_text, const std::string& source,
                   const std::vector<std::string>& overrides, const SettingsBody& body,
                   core::SettingsOrigins* origins = nullptr, const std::vector<std::string>& given_by = {});

/// Reads a YAML settings file (see read_settings).
void read_settings_file(const std::string& path, const std::vector<std::string>& overrides,
                        const SettingsBody& body, core::SettingsOrigins* origins = nullptr,
                        const std::vector<std::string>& given_by = {});

/// The effective settings as YAML, every field present, each commented with its unit
/// and description when `comments` is true. Reading it back gives the same settings.
std::string write_settings(const SettingsBody& body, bool comments = true);

}  // namespace talus::io
