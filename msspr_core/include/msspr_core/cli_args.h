// The one small command-line parser of the msspr tools ("--key value",
// "--key=value", "--flag"); header-only, no ROS and no torch, so the core,
// the environment tools and the ROS layer all share it. Every problem throws
// CliError with a message naming the flag; tools print it and exit 2.
#pragma once

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::cli {

// A bad command line (unknown flag, missing or malformed value, value out of range).
class CliError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// "--flag" parsed as a whole integer in [lo, hi]; throws CliError naming the flag.
inline long long ParseInt(const std::string& flag, const std::string& text,
                          long long lo = LLONG_MIN, long long hi = LLONG_MAX) {
  char* end = nullptr;
  errno = 0;
  const long long v = text.empty() ? 0 : std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE)
    throw CliError("--" + flag + " expects an integer, got '" + text + "'");
  if (v < lo || v > hi)
    throw CliError("--" + flag + " " + text + " is out of range (" + std::to_string(lo) + ".." +
                   std::to_string(hi) + ")");
  return v;
}

// A finite number in [lo, hi]; throws CliError naming the flag.
inline double ParseDouble(const std::string& flag, const std::string& text,
                          double lo = -std::numeric_limits<double>::max(),
                          double hi = std::numeric_limits<double>::max()) {
  char* end = nullptr;
  errno = 0;
  const double v = text.empty() ? 0 : std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw CliError("--" + flag + " expects a finite number, got '" + text + "'");
  if (v < lo || v > hi)
    throw CliError("--" + flag + " " + text + " is out of range (" + std::to_string(lo) + ".." +
                   std::to_string(hi) + ")");
  return v;
}

class CliArgs {
 public:
  // `flags` take no value; `options` take one. Unknown keys throw CliError
  // naming the key (ROS remappings "a:=b" are skipped).
  CliArgs(int argc, char** argv, const std::set<std::string>& flags,
          const std::set<std::string>& options) {
    for (int i = 1; i < argc; ++i) {
      std::string a = argv[i];
      if (a.find(":=") != std::string::npos) continue;
      if (a == "-h") a = "--help";
      if (a.rfind("--", 0) != 0) {
        positional_.push_back(a);
        continue;
      }
      std::string key = a.substr(2), value;
      const auto eq = key.find('=');
      if (eq != std::string::npos) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
        if (!options.count(key)) throw CliError("unknown option --" + key);
        values_[key] = value;
      } else if (flags.count(key)) {
        values_[key] = "1";
      } else if (options.count(key)) {
        if (i + 1 >= argc) throw CliError("option --" + key + " needs a value");
        values_[key] = argv[++i];
      } else {
        throw CliError("unknown option --" + key);
      }
    }
  }
  bool Has(const std::string& k) const { return values_.count(k) > 0; }
  std::string Get(const std::string& k, const std::string& def) const {
    auto it = values_.find(k);
    return it == values_.end() ? def : it->second;
  }
  long GetInt(const std::string& k, long def, long lo = LONG_MIN, long hi = LONG_MAX) const {
    return Has(k) ? static_cast<long>(ParseInt(k, values_.at(k), lo, hi)) : def;
  }
  double GetDouble(const std::string& k, double def,
                   double lo = -std::numeric_limits<double>::max(),
                   double hi = std::numeric_limits<double>::max()) const {
    return Has(k) ? ParseDouble(k, values_.at(k), lo, hi) : def;
  }
  // One of `choices`; throws CliError listing them.
  std::string GetChoice(const std::string& k, const std::string& def,
                        const std::set<std::string>& choices) const {
    const std::string v = Get(k, def);
    if (choices.count(v)) return v;
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    throw CliError("--" + k + " '" + v + "' is not one of: " + list);
  }
  // Comma-separated integers in [lo, hi].
  std::vector<long> GetIntList(const std::string& k, const std::string& def, long lo,
                               long hi) const {
    std::vector<long> out;
    const std::string s = Get(k, def);
    size_t start = 0;
    while (start <= s.size()) {
      const size_t comma = std::min(s.find(',', start), s.size());
      out.push_back(static_cast<long>(ParseInt(k, s.substr(start, comma - start), lo, hi)));
      start = comma + 1;
    }
    return out;
  }
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_;
};

}  // namespace msspr::cli
