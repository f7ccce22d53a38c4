// Internal: the YAML reader and writer of the options structs' Visit lists
// (options.cc, sac.cc). A section is a map of the struct's fields; unknown
// keys and values of the wrong type throw OptionsError naming the source.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <string>

#include "msspr_core/options.h"

namespace msspr {
namespace core {
namespace {

// Reads the fields of one section; remembers which keys were consumed.
class YamlReader {
 public:
  YamlReader(const YAML::Node& node, std::string section, std::string source)
      : node_(node), section_(std::move(section)), source_(std::move(source)) {}

  template <class T>
  void operator()(const char* key, T& value) {
    const YAML::Node child = node_[key];
    if (!child) return;
    seen_.insert(key);
    try {
      value = child.as<T>();
    } catch (const YAML::Exception& e) {
      throw OptionsError(source_ + ": bad value for '" + section_ + "." + key + "': " + e.what());
    }
  }

  void CheckNoUnknownKeys() const {
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!seen_.count(key)) {
        throw OptionsError(source_ + ": unknown key '" + section_ + "." + key + "'");
      }
    }
  }

 private:
  const YAML::Node& node_;
  std::string section_;
  std::string source_;
  std::set<std::string> seen_;
};

class YamlWriter {
 public:
  explicit YamlWriter(YAML::Emitter& out) : out_(out) {}
  template <class T>
  void operator()(const char* key, T& value) {
    out_ << YAML::Key << key << YAML::Value << value;
  }
  void operator()(const char* key, double& value) {
    out_ << YAML::Key << key << YAML::Value << ShortestRoundTrip(value);
  }

  // The fewest significant digits that read back as the same double: 0.3,
  // not 0.29999999999999999 (17 digits, the most any double needs).
  static std::string ShortestRoundTrip(double v) {
    std::string text;
    for (int digits = std::isfinite(v) ? 1 : 17; digits <= 17; ++digits) {
      std::ostringstream s;
      s.precision(digits);
      s << v;
      text = s.str();
      if (!std::isfinite(v) || std::strtod(text.c_str(), nullptr) == v) break;
    }
    return text;
  }

 private:
  YAML::Emitter& out_;
};

template <class S>
void ReadSection(const YAML::Node& root, const char* name, S& section, const std::string& source,
                 std::set<std::string>& seen) {
  const YAML::Node node = root[name];
  if (!node) return;
  seen.insert(name);
  if (!node.IsMap()) throw OptionsError(source + ": section '" + name + "' must be a map");
  YamlReader reader(node, name, source);
  section.Visit(reader);
  reader.CheckNoUnknownKeys();
}

template <class S>
void WriteSection(YAML::Emitter& out, const char* name, S section) {
  out << YAML::Key << name << YAML::Value << YAML::BeginMap;
  YamlWriter writer(out);
  section.Visit(writer);
  out << YAML::EndMap;
}

}  // namespace
}  // namespace core
}  // namespace msspr
