#include "talus/io/paths.hpp"

#include <cctype>
#include <filesystem>

#include "talus/core/error.hpp"

namespace talus::io {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace talus::io

namespace talus::io {
namespace {

namespace fs = std::filesystem;

// The absolute, normalised form with symbolic links of the existing part resolved.
fs::path resolved(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path).lexically_normal();
  return p;
}

std::string describe(const NamedPath& p) {
  return p.role == "input" ? "the input " + p.path : "the " + p.role + " " + p.path;
}

}  // namespace

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return resolved(a) == resolved(b);
}

bool inside_directory(const std::string& path, const std::string& dir) {
  if (path.empty() || dir.empty()) return false;
  const fs::path p = resolved(path);
  const fs::path d = resolved(dir);
  auto pi = p.begin();
  for (auto di = d.begin(); di != d.end(); ++di, ++pi) {
    if (di->empty()) continue;  // trailing separator
    if (pi == p.end() || *pi != *di) return false;
  }
  return pi != p.end();
}

void check_outputs_distinct(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs) {
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    const NamedPath& out = outputs[o];
    if (out.path.empty()) continue;
    for (const NamedPath& in : inputs)
      if (same_file(out.path, in.path))
        throw core::UsageError(out.role + " " + out.path + ": is " + describe(in) +
                               "; an output never overwrites an input (choose another name)");
    for (std::size_t k = 0; k < o; ++k)
      if (same_file(out.path, outputs[k].path))
        throw core::UsageError(out.role + " " + out.path + ": is also " + describe(outputs[k]) +
                               " of this call (choose another name)");
  }
}

}  // namespace talus::io

namespace talus::io {

void make_directories(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path))
    throw core::RuntimeError(path + ": cannot create the folder (" +
                             (ec ? ec.message() : std::string("a file of that name exists")) + ")");
}

}  // namespace talus::io
