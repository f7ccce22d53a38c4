// Internal: one torch module per named entry of a checkpoint archive. The key
// names are the checkpoint's (repr, critic, actor, target_*); keep them stable.
#pragma once

#include <string>

#include <torch/torch.h>

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

}  // namespace core
}  // namespace msspr
