#include "talus/io/atomic_output.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "talus/core/error.hpp"

namespace talus::io {

AtomicOutput::AtomicOutput(std::string final_path) : final_path_(std::move(final_path)) {
  const std::filesystem::path p(final_path_);
  if (p.filename().empty()) throw core::UsageError("output path '" + final_path_ + "' names no file");
  const auto dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(dir))
    throw core::RuntimeError(final_path_ + ": output directory does not exist");
  temp_path_ = (dir / ("." + p.filename().string() + ".tmp-" + std::to_string(::getpid()))).string();
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) std::remove(temp_path_.c_str());
}

void AtomicOutput::commit() {
  std::error_code ec;
  std::filesystem::rename(temp_path_, final_path_, ec);
  if (ec) throw core::RuntimeError(final_path_ + ": cannot write output (" + ec.message() + ")");
  committed_ = true;
}

void write_text_file(const std::string& path, const std::string& text) {
  AtomicOutput out(path);
  {
    std::ofstream file(out.temp_path(), std::ios::binary);
    file << text;
    file.flush();
    if (!file) throw core::RuntimeError(path + ": cannot write output");
  }
  out.commit();
}

}  // namespace talus::io
