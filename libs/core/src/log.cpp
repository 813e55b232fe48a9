#include "talus/core/log.hpp"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <string>

namespace talus::core {
namespace {
std::atomic<int> g_level{static_cast<int>(LogLevel::warn)};
std::mutex g_mutex;
std::string g_prefix = "talus";
}  // namespace

void set_log_level(LogLevel level) { g_level.store(static_cast<int>(level)); }
LogLevel log_level() { return static_cast<LogLevel>(g_level.load()); }

bool parse_log_level(std::string_view text, LogLevel& level) {
  if (text == "error") level = LogLevel::error;
  else if (text == "warn") level = LogLevel::warn;
  else if (text == "info") level = LogLevel::info;
  else if (text == "debug") level = LogLevel::debug;
  else return false;
  return true;
}

void set_log_prefix(std::string_view prefix) {
  std::lock_guard lock(g_mutex);
  g_prefix = prefix;
}

void log(LogLevel level, std::string_view message) {
  if (static_cast<int>(level) > g_level.load()) return;
  static constexpr const char* names[] = {"error", "warning", "info", "debug"};
  std::lock_guard lock(g_mutex);
  std::fprintf(stderr, "%s: %s: %.*s\n", g_prefix.c_str(), names[static_cast<int>(level)],
               static_cast<int>(message.size()), message.data());
}

void log_notice(std::string_view message) {
  if (g_level.load() < static_cast<int>(LogLevel::warn)) return;
  std::lock_guard lock(g_mutex);
  std::fprintf(stderr, "%s: %.*s\n", g_prefix.c_str(), static_cast<int>(message.size()), message.data());
}

}  // namespace talus::core
