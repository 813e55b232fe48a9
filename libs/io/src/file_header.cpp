#include "talus/io/file_header.hpp"

#include <cstdio>

#include "talus/core/error.hpp"

namespace talus::io {

void write_header(const h5::Group& root, const std::string& kind, SchemaVersion version,
                  const Provenance& provenance) {
  root.set_attr("talus_format", kind);
  root.set_attr("schema_version", std::to_string(version.major) + "." + std::to_string(version.minor));
  const h5::Group p = root.create_group("provenance");
  p.set_attr("tool", provenance.tool);
  p.set_attr("tool_version", provenance.tool_version);
  p.set_attr("settings_yaml", provenance.settings_yaml);
  p.set_attr("command_line", provenance.command_line);
  p.set_attr("seed", static_cast<std::int64_t>(provenance.seed));
  p.set_attr("inputs", provenance.inputs);
}

SchemaVersion check_header(const h5::Group& root, const std::string& kind, SchemaVersion supported) {
  const std::string& file = root.file_name();
  if (!root.has_attr("talus_format"))
    throw core::InputError(file, "not a Talus file (no 'talus_format' attribute)");
  const std::string found = root.attr_string("talus_format");
  if (found != kind)
    throw core::InputError(file, "is a Talus " + found + " file, expected a " + kind + " file");
  const std::string text = root.has_attr("schema_version") ? root.attr_string("schema_version") : "";
  SchemaVersion v{};
  if (std::sscanf(text.c_str(), "%d.%d", &v.major, &v.minor) != 2)
    throw core::InputError(file, "bad schema_version '" + text + "'");
  if (v.major != supported.major)
    throw core::InputError(file, kind + " schema version " + text + " is not supported (this build reads " +
                                     std::to_string(supported.major) + ".x)");
  return v;
}

Provenance read_provenance(const h5::Group& root) {
  const h5::Group p = root.open_group("provenance");
  Provenance out;
  out.tool = p.attr_string("tool");
  out.tool_version = p.attr_string("tool_version");
  out.settings_yaml = p.attr_string("settings_yaml");
  out.command_line = p.attr_string("command_line");
  out.seed = static_cast<std::uint64_t>(p.attr_int("seed"));
  out.inputs = p.has_attr("inputs") ? p.attr_string("inputs") : "";
  return out;
}

}  // namespace talus::io
