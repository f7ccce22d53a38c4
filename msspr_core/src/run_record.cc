#include "run_record.h"

#include <torch/torch.h>
#include <torch/version.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "msspr_core/cpu_info.h"
#include "msspr_core/process_env.h"

namespace msspr {
namespace core {
namespace internal {

const std::map<std::string, std::string> kRenamedFlags = {{"obs-mode", "observation-mode"}};

std::string CurrentFlagName(const std::string& key) {
  const auto it = kRenamedFlags.find(key);
  return it == kRenamedFlags.end() ? key : it->second;
}

RunRecord ReadRunRecord(const std::string& path) {
  RunRecord r;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (root["flags"])
      for (const auto& kv : root["flags"])
        r.flags[CurrentFlagName(kv.first.as<std::string>())] = kv.second.as<std::string>();
    if (root["config"])
      for (const auto& c : root["config"]) r.configs.push_back(c.as<std::string>());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": cannot read the run record: " + e.what());
  }
  return r;
}

void WriteTextAtomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) throw std::runtime_error(tmp + ": cannot open for writing: " + std::strerror(errno));
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) throw std::runtime_error(tmp + ": cannot write (disk full?)");
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot rename " + tmp + " to it: " + std::strerror(errno));
}

std::string BlasNote() {
  const std::string core = LoadedOpenBlasCore();
  return core.empty() ? "" : ", OpenBLAS kernels " + core;
}

std::string HostRecord(const std::string& precision_why) {
  std::ostringstream s;
  s << "# msspr_train: the machine, threads and precision of the run's latest segment\n"
    << "cpu:\n"
    << HostCpu().ToYaml("  ") << "torch_threads: " << torch::get_num_threads() << "\n"
    << "precision: \"" << precision_why << "\"\n"
    << "libtorch: \"" << TORCH_VERSION << "\"\n"
    << "openblas_core: \"" << LoadedOpenBlasCore() << "\"\n";
  return s.str();
}

void WriteRunRecord(const std::string& path, const RunRecord& r) {
  YAML::Emitter out;
  out << YAML::Comment("msspr_train run record: msspr_train --resume --out DIR reads it")
      << YAML::BeginMap;
  out << YAML::Key << "flags" << YAML::Value << YAML::BeginMap;
  for (const auto& [k, v] : r.flags)
    out << YAML::Key << k << YAML::Value << YAML::DoubleQuoted << v;
  out << YAML::EndMap << YAML::Key << "config" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : r.configs) out << YAML::DoubleQuoted << c;
  out << YAML::EndSeq << YAML::EndMap;
  WriteTextAtomically(path, std::string(out.c_str()) + "\n");
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
