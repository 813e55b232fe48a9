// SPDX-License-Identifier: MIT
#pragma once
#include <string_view>

namespace talus::core {

/// Log verbosity. Logging never changes results; it only reports.
enum class LogLevel { error = 0, warn = 1, info = 2, debug = 3 };

/// Sets the process-wide verbosity (tools set it from --log-level).
void set_log_level(LogLevel level);
LogLevel log_level();
/// Parses "error", "warn", "info" or "debug"; returns false on anything else.
bool parse_log_level(std::string_view text, LogLevel& level);
/// Sets the prefix of every log line (the tool name).
void set_log_prefix(std::string_view prefix);

/// Writes one line to stderr when `level` is enabled. Thread-safe.
void log(LogLevel level, std::string_view message);
inline void log_warn(std::string_view message) { log(LogLevel::warn, message); }
inline void log_info(std::string_view message) { log(LogLevel::info, message); }
inline void log_debug(std::string_view message) { log(LogLevel::debug, message); }
/// Progress and end-of-run summaries: shown at the default level (hidden by -q), as
/// "PREFIX: MESSAGE" without a level label.
void log_notice(std::string_view message);

}  // namespace talus::core
