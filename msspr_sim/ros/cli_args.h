// A small "--key value" / "--flag" command-line parser for the msspr tools,
// which must also run under rosrun without a master.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::ros_bridge {

class CliArgs {
 public:
  // `flags` take no value; `options` take one. Unknown keys throw
  // std::invalid_argument naming the key (ROS remappings "a:=b" are skipped).
  CliArgs(int argc, char** argv, const std::set<std::string>& flags,
          const std::set<std::string>& options) {
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      if (a.find(":=") != std::string::npos) continue;
      if (a.rfind("--", 0) != 0) {
        positional_.push_back(a);
        continue;
      }
      std::string key = a.substr(2), value;
      const auto eq = key.find('=');
      if (eq != std::string::npos) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
        if (!options.count(key)) throw std::invalid_argument("unknown option --" + key);
        values_[key] = value;
      } else if (flags.count(key)) {
        values_[key] = "1";
      } else if (options.count(key)) {
        if (i + 1 >= argc) throw std::invalid_argument("option --" + key + " needs a value");
        values_[key] = argv[++i];
      } else {
        throw std::invalid_argument("unknown option --" + key);
      }
    }
  }
  bool Has(const std::string& k) const { return values_.count(k) > 0; }
  std::string Get(const std::string& k, const std::string& def) const {
    auto it = values_.find(k);
    return it == values_.end() ? def : it->second;
  }
  long GetInt(const std::string& k, long def) const {
    if (!Has(k)) return def;
    try {
      size_t pos = 0;
      long v = std::stol(values_.at(k), &pos);
      if (pos != values_.at(k).size()) throw std::invalid_argument("");
      return v;
    } catch (const std::exception&) {
      throw std::invalid_argument("--" + k + " expects an integer, got '" + values_.at(k) + "'");
    }
  }
  double GetDouble(const std::string& k, double def) const {
    if (!Has(k)) return def;
    try {
      size_t pos = 0;
      double v = std::stod(values_.at(k), &pos);
      if (pos != values_.at(k).size()) throw std::invalid_argument("");
      return v;
    } catch (const std::exception&) {
      throw std::invalid_argument("--" + k + " expects a number, got '" + values_.at(k) + "'");
    }
  }
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

}  // namespace msspr::ros_bridge
