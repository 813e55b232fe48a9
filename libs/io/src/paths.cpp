#include "talus/io/paths.hpp"

#include <cctype>
#include <filesystem>

namespace talus::io {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace talus::io
