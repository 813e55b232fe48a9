#include "talus/io/settings_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <type_traits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "talus/core/error.hpp"

namespace talus::io {
namespace {

using core::InputError;
using core::SettingsVisitor;

// A value put into the YAML tree by --set KEY=VALUE: messages about it name "--set KEY"
// (its label), not the settings file and a line the value never was on.
struct SetValue {
  YAML::Node node;
  std::string key;
  std::string label;
};
using SetValues = std::vector<SetValue>;

// Every key path of the settings `body` declares ("release.main_direction_deg"), from the
// YAML of its effective settings (the items of lists are not entered).
void key_paths(const YAML::Node& map, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& kv : map) {
    const std::string path = prefix + kv.first.as<std::string>();
    out.push_back(path);
    if (kv.second.IsMap()) key_paths(kv.second, path + ".", out);
  }
}

// The declared key path an unknown key was likely meant for, at another level: one whose
// last part is the unknown key's last part (`exact`), else within two edits of it (the
// shortest such path). Empty when none is.
std::string elsewhere(const std::string& unknown, const SettingsBody& body, bool& exact) {
  std::vector<std::string> paths;
  key_paths(YAML::Load(write_settings(body, false)), "", paths);
  const auto last = [](const std::string& path) {
    const auto dot = path.rfind('.');
    return dot == std::string::npos ? path : path.substr(dot + 1);
  };
  const std::string key = last(unknown);
  std::string best;
  std::size_t best_distance = 3;
  for (const std::string& path : paths) {
    if (path == unknown) continue;
    const std::size_t d = core::edit_distance(key, last(path));
    if (d < best_distance || (d == best_distance && !best.empty() && path.size() < best.size())) {
      best_distance = d;
      best = path;
    }
  }
  exact = !best.empty() && best_distance == 0;
  return best;
}

// Reads one mapping node into a settings struct, remembering the keys it consumed.
class Reader final : public SettingsVisitor {
 public:
  Reader(YAML::Node node, std::string source, std::string prefix, const SetValues& set_values,
         core::SettingsOrigins& origins, bool from_set = false)
      : node_(std::move(node)), source_(std::move(source)), prefix_(std::move(prefix)),
        set_values_(set_values), origins_(origins), from_set_(from_set) {}

  /// The whole settings' declaration, for suggesting a key of another section (nested
  /// readers share it).
  void declared_by(const SettingsBody* body) { body_ = body; }

  void field(std::string_view key, double& value, std::string_view, std::string_view) override {
    if (auto n = take(key)) value = to_double(*n, key);
  }
  void field(std::string_view key, std::optional<double>& value, std::string_view,
             std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      if (n.IsNull()) value.reset();
      else value = to_double(n, key);
    }
  }
  void field(std::string_view key, std::int64_t& value, std::string_view, std::string_view) override {
    if (auto n = take(key)) value = to_integer<std::int64_t>(*n, key, "an integer");
  }
  void field(std::string_view key, std::uint64_t& value, std::string_view, std::string_view) override {
    if (auto n = take(key)) value = to_integer<std::uint64_t>(*n, key, "a non-negative integer");
  }
  void field(std::string_view key, bool& value, std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      try {
        if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "");
        value = n.as<bool>();
      } catch (const YAML::Exception&) {
        fail(n, key, "expected true or false, got " + describe(n));
      }
    }
  }
  void field(std::string_view key, std::string& value, std::string_view) override {
    if (auto n = take(key)) value = to_string(*n, key);
  }
  void field(std::string_view key, std::array<double, 3>& value, std::string_view,
             std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      if (!n.IsSequence() || n.size() != 3) fail(n, key, "expected a list of 3 numbers");
      for (std::size_t i = 0; i < 3; ++i) value[i] = to_double(n[i], key);
    }
  }
  void field(std::string_view key, std::vector<double>& value, std::string_view,
             std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      if (!n.IsSequence()) fail(n, key, "expected a list of numbers");
      value.clear();
      for (const auto& item : n) value.push_back(to_double(item, key));
    }
  }
  void field(std::string_view key, std::vector<std::string>& value, std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      value.clear();
      if (n.IsScalar()) {
        value.push_back(to_string(n, key));
        return;
      }
      if (!n.IsSequence()) fail(n, key, "expected a list of strings");
      for (const auto& item : n) value.push_back(to_string(item, key));
    }
  }
  void field(std::string_view key, std::vector<std::array<double, 2>>& value, std::string_view,
             std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      if (!n.IsSequence()) fail(n, key, "expected a list of [x, y] points");
      value.clear();
      for (const auto& item : n) {
        if (!item.IsSequence() || item.size() != 2) fail(item, key, "expected an [x, y] point");
        value.push_back({to_double(item[0], key), to_double(item[1], key)});
      }
    }
  }
  void bounded(std::string_view key, double& value, std::string_view unit, std::string_view,
               const core::Range& range) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      value = to_double(n, key);
      check_range(n, key, value, unit, range);
    }
  }
  void bounded(std::string_view key, std::optional<double>& value, std::string_view unit, std::string_view,
               const core::Range& range) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      if (n.IsNull()) {
        value.reset();
        return;
      }
      value = to_double(n, key);
      check_range(n, key, *value, unit, range);
    }
  }
  void bounded(std::string_view key, std::array<double, 3>& value, std::string_view unit, std::string_view doc,
               const core::Range& range) override {
    field(key, value, unit, doc);
    if (auto found = peek(key))
      for (std::size_t i = 0; i < 3; ++i) check_range((*found)[i], key, value[i], unit, range);
  }
  void bounded(std::string_view key, std::int64_t& value, std::string_view unit, std::string_view,
               const core::Range& range) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      value = to_integer<std::int64_t>(n, key, "an integer");
      check_range(n, key, static_cast<double>(value), unit, range);
    }
  }
  void choice(std::string_view key, std::string& value, std::initializer_list<std::string_view> allowed,
              std::string_view) override {
    if (auto found = take(key)) {
      const YAML::Node& n = *found;
      const std::string text = to_string(n, key);
      std::string list;
      for (auto a : allowed) {
        if (a == text) {
          value = text;
          return;
        }
        list += (list.empty() ? "" : ", ") + std::string(a);
      }
      fail(n, key, "'" + text + "' is not one of: " + list);
    }
  }
  void section(std::string_view key, std::string_view,
               const std::function<void(SettingsVisitor&)>& body) override {
    auto found = take(key);
    // `--set release=` would reset a whole section to its defaults without a word.
    if (found && found->IsNull() && !set_label(*found).empty())
      fail(*found, key, "expected a mapping of settings, got nothing (give KEY.SUBKEY=VALUE)");
    if (!found || found->IsNull()) {
      // Absent section: visit with an empty map so defaults stay; nothing to check.
      Reader inner(YAML::Node(YAML::NodeType::Map), source_, path(key), set_values_, origins_, from_set_);
      body(inner);
      return;
    }
    const YAML::Node& n = *found;
    if (!n.IsMap()) fail(n, key, "expected a mapping of settings");
    Reader inner = nested(n, key, path(key));
    body(inner);
    inner.check_unknown();
  }
  void list(std::string_view key, std::string_view, const ListAccess& items) override {
    auto found = take(key);
    if (found && found->IsNull() && !set_label(*found).empty())
      fail(*found, key, "expected a list, got nothing (give [] for an empty list)");
    if (!found || found->IsNull()) {
      // Absent list: keep the defaults, but still visit them so nested defaults settle.
      for (std::size_t i = 0; i < items.size(); ++i) {
        Reader inner(YAML::Node(YAML::NodeType::Map), source_, path(key), set_values_, origins_, from_set_);
        items.visit_item(i, inner);
      }
      return;
    }
    const YAML::Node& n = *found;
    if (!n.IsSequence()) fail(n, key, "expected a list");
    items.resize(n.size());
    for (std::size_t i = 0; i < n.size(); ++i) {
      const YAML::Node item = n[i];
      const std::string item_path = path(key) + "[" + std::to_string(i) + "]";
      if (!item.IsMap()) fail(item, key, "item " + std::to_string(i) + ": expected a mapping");
      Reader inner = nested(item, key, item_path);
      origins_.record(item_path, inner.from_set_ ? inner.source_ : location(item));
      items.visit_item(i, inner);
      inner.check_unknown();
    }
  }

  // Any key of this mapping nobody asked for is an error: a typo never runs silently.
  void check_unknown() const {
    if (!node_.IsMap()) return;
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (seen_.count(key)) continue;
      std::string hint;
      std::size_t best = 3;
      for (const auto& known : seen_all_) {
        const std::size_t d = core::edit_distance(key, known);
        if (d < best) {
          best = d;
          hint = " (did you mean '" + path(known) + "'?)";
        }
      }
      // A key of another section (main_direction_deg given at the top for
      // release.main_direction_deg): suggested when it has that key's very name, or when
      // nothing at this level is close.
      if (body_ != nullptr) {
        bool exact = false;
        const std::string meant = elsewhere(path(key), *body_, exact);
        if (!meant.empty() && (hint.empty() || exact)) hint = " (did you mean '" + meant + "'?)";
      }
      throw InputError(unknown_key_location(kv, path(key)), "unknown key '" + path(key) + "'" + hint);
    }
  }

 private:
  // The node under `key`, or nothing when the key is absent.
  std::optional<YAML::Node> take(std::string_view key) {
    const std::string k(key);
    seen_all_.insert(k);
    if (!node_.IsMap()) return std::nullopt;
    // Const lookup: a missing key gives an undefined node instead of inserting one.
    const YAML::Node& map = node_;
    YAML::Node n = map[k];
    if (!n.IsDefined()) return std::nullopt;
    seen_.insert(k);
    origins_.record(path(key), origin(k, n));
    return n;
  }
  // Where the value `n` of `key` came from: the --set that gave it (or the part of the
  // tree it is in), else the line of the key in the file.
  std::string origin(const std::string& key, const YAML::Node& n) const {
    if (const std::string from = set_label(n); !from.empty()) return from;
    if (from_set_) return source_;
    for (const auto& kv : node_)
      if (kv.first.IsScalar() && kv.first.Scalar() == key) return location(kv.first);
    return location(n);
  }
  // The node under `key` without marking it consumed.
  std::optional<YAML::Node> peek(std::string_view key) const {
    if (!node_.IsMap()) return std::nullopt;
    const YAML::Node& map = node_;
    YAML::Node n = map[std::string(key)];
    if (!n.IsDefined()) return std::nullopt;
    return n;
  }
  // Where an unknown key came from: the --set whose key path runs through it, else the file.
  std::string unknown_key_location(const std::pair<YAML::Node, YAML::Node>& kv, const std::string& full) const {
    if (const std::string from = set_label(kv.second); !from.empty()) return from;
    for (const auto& s : set_values_) {
      const std::string& k = s.key;
      if (k == full || (k.size() > full.size() && k.compare(0, full.size(), full) == 0 &&
                        (k[full.size()] == '.' || k[full.size()] == '[')))
        return s.label;
    }
    return location(kv.first);
  }
  // The label ("--set KEY") of the override that put `n` into the tree, or "".
  std::string set_label(const YAML::Node& n) const {
    for (const auto& s : set_values_)
      if (n.is(s.node)) return s.label;
    return {};
  }
  // The reader of a nested mapping: named after its --set key when --set gave all of it.
  Reader nested(const YAML::Node& n, std::string_view key, const std::string& prefix) const {
    Reader inner = [&] {
      const std::string from = set_label(n);
      if (!from.empty()) return Reader(n, from, prefix, set_values_, origins_, true);
      if (auto top = peek(key)) {
        const std::string whole = set_label(*top);
        if (!whole.empty()) return Reader(n, whole, prefix, set_values_, origins_, true);
      }
      return Reader(n, source_, prefix, set_values_, origins_, from_set_);
    }();
    inner.declared_by(body_);
    return inner;
  }
  void check_range(const YAML::Node& n, std::string_view key, double value, std::string_view unit,
                   const core::Range& range) const {
    if (!range.contains(value))
      fail(n, key, "must be in " + range.text(unit) + ", got " + core::format_number(value));
  }
  std::string path(std::string_view key) const {
    return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
  }
  std::string location(const YAML::Node& n) const {
    if (from_set_) return source_;
    const auto mark = n.Mark();
    if (mark.line < 0) return source_;
    return source_ + ":" + std::to_string(mark.line + 1);
  }
  static std::string describe(const YAML::Node& n) {
    if (n.IsScalar()) return "'" + n.Scalar() + "'";
    if (n.IsSequence()) return "a list";
    if (n.IsMap()) return "a mapping";
    return "nothing";
  }
  [[noreturn]] void fail(const YAML::Node& n, std::string_view key, const std::string& what) const {
    // A value given by --set KEY=... is named by that KEY, which already says the path.
    if (auto top = peek(key)) {
      const std::string from = set_label(*top);
      if (!from.empty()) throw InputError(from, what);
    }
    throw InputError(location(n), path(key) + ": " + what);
  }
  double to_double(const YAML::Node& n, std::string_view key) const {
    if (!n.IsScalar()) fail(n, key, "expected a number, got " + describe(n));
    const std::string& text = n.Scalar();
    // YAML's own spellings of the non-finite numbers.
    static const std::set<std::string> non_finite = {".nan", ".NaN", ".NAN", ".inf", ".Inf", ".INF",
                                                      "+.inf", "+.Inf", "+.INF", "-.inf", "-.Inf", "-.INF"};
    if (non_finite.count(text)) fail(n, key, "must be finite, got " + describe(n));
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size())
      fail(n, key, "expected a number, got " + describe(n));
    if (!std::isfinite(v)) fail(n, key, "must be finite, got " + describe(n));
    return v;
  }
  template <class T>
  T to_integer(const YAML::Node& n, std::string_view key, const char* what) const {
    if (!n.IsScalar()) fail(n, key, std::string("expected ") + what + ", got " + describe(n));
    const std::string& text = n.Scalar();
    if (text.empty() || (std::is_unsigned_v<T> && text[0] == '-'))
      fail(n, key, std::string("expected ") + what + ", got " + describe(n));
    errno = 0;
    char* end = nullptr;
    T v{};
    if constexpr (std::is_unsigned_v<T>) v = std::strtoull(text.c_str(), &end, 10);
    else v = std::strtoll(text.c_str(), &end, 10);
    if (errno == ERANGE || end != text.c_str() + text.size())
      fail(n, key, std::string("expected ") + what + ", got " + describe(n));
    return v;
  }
  std::string to_string(const YAML::Node& n, std::string_view key) const {
    if (!n.IsScalar()) fail(n, key, "expected a string, got " + describe(n));
    return n.Scalar();
  }

  YAML::Node node_;
  std::string source_;
  std::string prefix_;
  std::set<std::string> seen_;
  std::set<std::string> seen_all_;
  const SetValues& set_values_;
  core::SettingsOrigins& origins_;
  bool from_set_ = false;
  const SettingsBody* body_ = nullptr;
};

// Emits the effective settings.
class Writer final : public SettingsVisitor {
 public:
  Writer(YAML::Emitter& out, bool comments) : out_(out), comments_(comments) {}

  void field(std::string_view key, double& value, std::string_view unit, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << number(value);
    comment(unit, doc);
  }
  void field(std::string_view key, std::optional<double>& value, std::string_view unit,
             std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value;
    if (value) out_ << number(*value);
    else out_ << YAML::Null;
    comment(unit, doc);
  }
  void field(std::string_view key, std::int64_t& value, std::string_view unit, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
    comment(unit, doc);
  }
  void field(std::string_view key, std::uint64_t& value, std::string_view unit, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
    comment(unit, doc);
  }
  void field(std::string_view key, bool& value, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
    comment({}, doc);
  }
  void field(std::string_view key, std::string& value, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::DoubleQuoted << value;
    comment({}, doc);
  }
  void field(std::string_view key, std::array<double, 3>& value, std::string_view unit,
             std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (double v : value) out_ << number(v);
    out_ << YAML::EndSeq;
    comment(unit, doc);
  }
  void field(std::string_view key, std::vector<double>& value, std::string_view unit,
             std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (double v : value) out_ << number(v);
    out_ << YAML::EndSeq;
    comment(unit, doc);
  }
  void field(std::string_view key, std::vector<std::string>& value, std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& v : value) out_ << YAML::DoubleQuoted << v;
    out_ << YAML::EndSeq;
    comment({}, doc);
  }
  void field(std::string_view key, std::vector<std::array<double, 2>>& value, std::string_view unit,
             std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : value) out_ << YAML::Flow << YAML::BeginSeq << number(p[0]) << number(p[1]) << YAML::EndSeq;
    out_ << YAML::EndSeq;
    comment(unit, doc);
  }
  void bounded(std::string_view key, double& value, std::string_view unit, std::string_view doc,
               const core::Range& range) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << number(value);
    comment(unit, with_range(doc, range));
  }
  void bounded(std::string_view key, std::optional<double>& value, std::string_view unit, std::string_view doc,
               const core::Range& range) override {
    out_ << YAML::Key << std::string(key) << YAML::Value;
    if (value) out_ << number(*value);
    else out_ << YAML::Null;
    comment(unit, with_range(doc, range));
  }
  void bounded(std::string_view key, std::array<double, 3>& value, std::string_view unit, std::string_view doc,
               const core::Range& range) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (double v : value) out_ << number(v);
    out_ << YAML::EndSeq;
    comment(unit, with_range(doc, range));
  }
  void bounded(std::string_view key, std::int64_t& value, std::string_view unit, std::string_view doc,
               const core::Range& range) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
    comment(unit, with_range(doc, range));
  }
  void choice(std::string_view key, std::string& value, std::initializer_list<std::string_view> allowed,
              std::string_view doc) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
    std::string options = std::string(doc) + " (one of:";
    for (auto a : allowed) options += " " + std::string(a);
    comment({}, options + ")");
  }
  void section(std::string_view key, std::string_view doc,
               const std::function<void(SettingsVisitor&)>& body) override {
    // On a line of its own above the key (a bare Comment would trail the previous value).
    if (comments_ && !doc.empty()) out_ << YAML::Newline << YAML::Comment(std::string(doc));
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::BeginMap;
    body(*this);
    out_ << YAML::EndMap;
  }
  void list(std::string_view key, std::string_view doc, const ListAccess& items) override {
    // On a line of its own above the key (a bare Comment would trail the previous value).
    if (comments_ && !doc.empty()) out_ << YAML::Newline << YAML::Comment(std::string(doc));
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::BeginSeq;
    for (std::size_t i = 0; i < items.size(); ++i) {
      out_ << YAML::BeginMap;
      items.visit_item(i, *this);
      out_ << YAML::EndMap;
    }
    out_ << YAML::EndSeq;
  }

 private:
  // Shortest text that reads back as the same double.
  static std::string number(double v) {
    char buffer[40];
    for (int precision = 6; precision <= 17; ++precision) {
      std::snprintf(buffer, sizeof buffer, "%.*g", precision, v);
      if (std::strtod(buffer, nullptr) == v) break;
    }
    return buffer;
  }
  static std::string with_range(std::string_view doc, const core::Range& range) {
    return std::string(doc) + "; in " + range.text();
  }
  void comment(std::string_view unit, std::string_view doc) {
    if (!comments_) return;
    std::string text;
    if (!unit.empty()) text = "[" + std::string(unit) + "] ";
    text += doc;
    if (!text.empty()) out_ << YAML::Comment(text);
  }
  YAML::Emitter& out_;
  bool comments_;
};

// Applies one "a.b[2].c=value" override to the YAML tree.
// `defaults` is the tree of the default settings: a key the file does not give is filled
// from it, so `--set materials[0].restitution_mean=0.9` reaches the default list's item.
void apply_override(YAML::Node& root, const std::string& text, const std::string& given_by, SetValues& set_values,
                    const YAML::Node& defaults) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw core::UsageError("--set expects key=value, got '" + text + "'");
  const std::string key = text.substr(0, eq);
  const std::string value = text.substr(eq + 1);
  YAML::Node parsed;
  try {
    parsed = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    throw core::UsageError("--set " + key + ": cannot parse value '" + value + "'");
  }
  set_values.push_back({parsed, key, given_by + " " + key});
  // Split on '.' and on [index].
  std::vector<std::string> parts;
  std::string current;
  for (char c : key) {
    if (c == '.' || c == '[') {
      if (!current.empty()) parts.push_back(current);
      current.clear();
      if (c == '[') current = "[";
    } else if (c == ']') {
      parts.push_back(current + "]");
      current.clear();
    } else {
      current += c;
    }
  }
  if (!current.empty()) parts.push_back(current);
  if (parts.empty()) throw core::UsageError("--set: empty key in '" + text + "'");

  // yaml-cpp nodes are references: walk by reassigning handles.
  std::vector<YAML::Node> chain{root};
  // The same place in the default tree (a null node when it has none). yaml-cpp's
  // assignment writes through a node, so the walk pushes handles instead.
  std::vector<YAML::Node> fallbacks{defaults};
  for (std::size_t i = 0; i < parts.size(); ++i) {
    YAML::Node node = chain.back();
    const std::string& part = parts[i];
    const bool last = i + 1 == parts.size();
    if (part.front() == '[') {
      std::size_t index = 0;
      try {
        index = std::stoul(part.substr(1, part.size() - 2));
      } catch (...) {
        throw core::UsageError("--set " + key + ": bad list index " + part);
      }
      if (!node.IsSequence() || index >= node.size())
        throw core::UsageError("--set " + key + ": no list item " + part);
      const YAML::Node& f = fallbacks.back();
      fallbacks.push_back(f.IsSequence() && index < f.size() ? f[index] : YAML::Node());
      if (last) node[index] = parsed;
      else chain.push_back(node[index]);
    } else {
      if (node.IsNull()) node = YAML::Node(YAML::NodeType::Map);
      if (!node.IsMap()) throw core::UsageError("--set " + key + ": '" + part + "' is not in a mapping");
      const YAML::Node& f = fallbacks.back();
      fallbacks.push_back(f.IsMap() && f[part] ? f[part] : YAML::Node());
      const YAML::Node& fallback = fallbacks.back();
      if (last) node[part] = parsed;
      else {
        if (!node[part]) {
          // An item of a default list is reached through a copy of that list.
          const bool list_next = parts[i + 1].front() == '[';
          node[part] = list_next && fallback.IsSequence() ? YAML::Clone(fallback) : YAML::Node(YAML::NodeType::Map);
        }
        chain.push_back(node[part]);
      }
    }
  }
}

// Refuses a mapping that gives a key twice, at any depth: YAML forbids it, and a parser
// that takes the first (or the last) would silently drop the other value, such as an
// override appended at the end of a file.
void check_unique_keys(const YAML::Node& node, const std::string& source, int depth = 0) {
  // No setting nests this deep; an alias inside its own anchor (a: &a [*a]) nests forever.
  constexpr int kMaxDepth = 64;
  if (depth > kMaxDepth)
    throw InputError(source + ":" + std::to_string(node.Mark().line + 1),
                     "values nested more than " + std::to_string(kMaxDepth) +
                         " levels deep (an alias inside its own anchor?)");
  if (node.IsSequence()) {
    for (const auto& item : node) check_unique_keys(item, source, depth + 1);
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, int> first_line;
  for (const auto& pair : node) {
    if (pair.first.IsScalar()) {
      const std::string key = pair.first.Scalar();
      const int line = pair.first.Mark().line + 1;
      const auto [at, inserted] = first_line.emplace(key, line);
      if (!inserted)
        throw InputError(source + ":" + std::to_string(line),
                         "duplicate key '" + key + "' (first given at line " + std::to_string(at->second) + ")");
    }
    check_unique_keys(pair.second, source, depth + 1);
  }
}

}  // namespace

void read_settings(const std::string& yaml_text, const std::string& source,
                   const std::vector<std::string>& overrides, const SettingsBody& body,
                   core::SettingsOrigins* origins, const std::vector<std::string>& given_by) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw InputError(source + ":" + std::to_string(e.mark.line + 1), "YAML syntax error: " + e.msg);
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) throw InputError(source, "expected a mapping of settings at the top level");
  check_unique_keys(root, source);
  SetValues set_values;
  const YAML::Node defaults = overrides.empty() ? YAML::Node() : YAML::Load(write_settings(body, false));
  for (std::size_t k = 0; k < overrides.size(); ++k)
    apply_override(root, overrides[k], k < given_by.size() ? given_by[k] : "--set", set_values, defaults);
  core::SettingsOrigins unused(source);
  Reader reader(root, source, "", set_values, origins != nullptr ? *origins : unused);
  reader.declared_by(&body);
  body(reader);
  reader.check_unknown();
}

void read_settings_file(const std::string& path, const std::vector<std::string>& overrides,
                        const SettingsBody& body, core::SettingsOrigins* origins,
                        const std::vector<std::string>& given_by) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "is a directory, not a settings file");
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open settings file");
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, "cannot read settings file");
  read_settings(text.str(), path, overrides, body, origins, given_by);
}

std::string write_settings(const SettingsBody& body, bool comments) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  Writer writer(out, comments);
  body(writer);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace talus::io
