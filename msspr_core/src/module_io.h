// Internal: one torch module per named entry of a checkpoint archive. The key
// names are the checkpoint's (repr, critic, actor, target_*); keep them stable.
#pragma once

#include <torch/torch.h>

#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "msspr_core/checkpoint.h"

namespace msspr {
namespace core {

inline void WriteModule(torch::serialize::OutputArchive& archive, const std::string& key,
                        const torch::nn::Module& module) {
  torch::serialize::OutputArchive sub;
  module.save(sub);
  archive.write(key, sub);
}

inline void ReadModule(torch::serialize::InputArchive& archive, const std::string& key,
                       torch::nn::Module& module) {
  torch::serialize::InputArchive sub;
  archive.read(key, sub);
  module.load(sub);
}

// Writes `archive` as the payload of a checkpoint file of `kind` with the YAML
// `header` (the current format version). Atomic (WriteCheckpointFile); with
// `keep_previous` the file it replaces is kept as PATH.prev.
inline void WriteArchiveFile(const std::string& path, const std::string& kind,
                             const std::string& header, torch::serialize::OutputArchive& archive,
                             bool keep_previous = false) {
  CheckpointFile file;
  file.kind = kind;
  file.version = kCheckpointFormatVersion;
  file.header = header;
  std::ostringstream payload;
  archive.save_to(payload);
  file.payload = payload.str();
  WriteCheckpointFile(path, file, keep_previous);
}

// Writes an inference export (kind "policy"): a header with `options` and
// `step`, then each (key, module): "repr", "actor", "critic" for Ms.PR,
// "agent" for a baseline. Atomic (WriteCheckpointFile).
inline void WritePolicyExport(
    const std::string& path, const MsprOptions& options, int64_t step,
    const std::vector<std::pair<std::string, const torch::nn::Module*>>& modules) {
  CheckpointHeader header;
  header.options = options;
  header.step = step;
  torch::serialize::OutputArchive archive;
  for (const auto& [key, module] : modules) WriteModule(archive, key, *module);
  WriteArchiveFile(path, "policy", CheckpointHeaderToYaml(header), archive);
}

}  // namespace core
}  // namespace msspr
