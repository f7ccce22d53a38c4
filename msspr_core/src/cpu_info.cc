#include "msspr_core/cpu_info.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <sstream>

namespace msspr {
namespace core {
namespace {

const std::vector<std::string>& FlagsThatMatter() {
  static const std::vector<std::string> flags{"avx2",     "fma",      "avx512f",    "avx512_bf16",
                                              "amx_bf16", "amx_tile", "avx512_fp16"};
  return flags;
}

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out + "\"";
}

int ToInt(const std::string& s) {
  try {
    return std::stoi(s);
  } catch (...) {
    return -1;
  }
}

}  // namespace

bool CpuInfo::Has(const std::string& flag) const {
  return std::find(flags.begin(), flags.end(), flag) != flags.end();
}

std::string CpuInfo::Summary() const {
  std::ostringstream s;
  s << (model_name.empty() ? "unknown CPU" : model_name) << " (";
  if (!vendor.empty()) s << vendor << " ";
  s << "family " << family << " model " << model << ";";
  if (flags.empty()) s << " no AVX2";
  for (const auto& f : flags) s << " " << f;
  s << ")";
  return s.str();
}

std::string CpuInfo::ToJson() const {
  std::ostringstream s;
  s << "{\"model_name\": " << JsonString(model_name) << ", \"vendor\": " << JsonString(vendor)
    << ", \"family\": " << family << ", \"model\": " << model
    << ", \"logical_cpus\": " << logical_cpus << ", \"flags\": [";
  for (size_t i = 0; i < flags.size(); ++i) s << (i ? ", " : "") << JsonString(flags[i]);
  s << "]}";
  return s.str();
}

std::string CpuInfo::ToYaml(const std::string& indent) const {
  std::ostringstream s;
  s << indent << "model_name: " << JsonString(model_name) << "\n"
    << indent << "vendor: " << JsonString(vendor) << "\n"
    << indent << "family: " << family << "\n"
    << indent << "model: " << model << "\n"
    << indent << "logical_cpus: " << logical_cpus << "\n"
    << indent << "flags: [";
  for (size_t i = 0; i < flags.size(); ++i) s << (i ? ", " : "") << flags[i];
  s << "]\n";
  return s.str();
}

CpuInfo ParseCpuInfo(const std::string& text) {
  CpuInfo info;
  std::istringstream in(text);
  std::string line;
  bool first = true;  // the first processor's block gives the fields
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      if (info.logical_cpus > 0) first = false;  // a blank line ends a block
      continue;
    }
    const std::string key = Trim(line.substr(0, colon)), value = Trim(line.substr(colon + 1));
    if (key == "processor") ++info.logical_cpus;
    if (!first) continue;
    if (key == "model name") {
      info.model_name = value;
    } else if (key == "vendor_id") {
      info.vendor = value;
    } else if (key == "cpu family") {
      info.family = ToInt(value);
    } else if (key == "model") {
      info.model = ToInt(value);
    } else if (key == "flags") {
      std::set<std::string> present;
      std::istringstream words(value);
      for (std::string w; words >> w;) present.insert(w);
      for (const auto& f : FlagsThatMatter())
        if (present.count(f)) info.flags.push_back(f);
    }
  }
  return info;
}

const CpuInfo& HostCpu() {
  static const CpuInfo info = [] {
    std::ifstream f("/proc/cpuinfo");
    std::stringstream text;
    text << f.rdbuf();
    return ParseCpuInfo(text.str());
  }();
  return info;
}

}  // namespace core
}  // namespace msspr
