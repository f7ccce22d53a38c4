// The trainer's checkpoint I/O: training state (weights, optimisers, random
// streams, per-rank states) written atomically and restored bit-exact, and
// policy exports.
#include <sstream>

#include "module_io.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/trainer.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

namespace {

// NaN guard: a training run stops (std::runtime_error) rather than write
// non-finite weights over the last good checkpoint.
void CheckFiniteWeights(const std::vector<torch::nn::Module*>& modules, int64_t step,
                        const std::string& what) {
  for (torch::nn::Module* m : modules) {
    for (const auto& p : m->named_parameters()) {
      if (!torch::isfinite(p.value()).all().item<bool>())
        throw std::runtime_error("training diverged: weight '" + m->name() + "." + p.key() +
                                 "' is NaN or Inf at step " + std::to_string(step) + "; " + what +
                                 " not written (the last good checkpoint is kept)");
    }
  }
}

// The sections that shape the networks (network, and the baseline agent's),
// to check that a checkpoint fits this trainer.
std::string NetworkYaml(const MsprOptions& options) {
  MsprOptions o;
  o.network = options.network;
  const BaselineOptions& b = options.baseline;
  o.baseline.agent = b.agent;
  o.baseline.hidden = b.hidden;
  o.baseline.layers = b.layers;
  o.baseline.latent_dim = b.latent_dim;
  o.baseline.iqe_dim = b.iqe_dim;
  o.baseline.rep_dim = b.rep_dim;
  return OptionsToYaml(o);
}

}  // namespace

std::string Trainer::RandomStateText() {
  std::ostringstream out;
  out << rng_ << "|";
  const torch::Tensor state = gen_.get_state().contiguous();
  static const char* kHex = "0123456789abcdef";
  const uint8_t* p = state.data_ptr<uint8_t>();
  for (int64_t i = 0; i < state.numel(); ++i) out << kHex[p[i] >> 4] << kHex[p[i] & 15];
  return out.str();
}

void Trainer::RestoreRandomState(const std::string& text, const std::string& path) {
  const size_t bar = text.find('|');
  if (bar == std::string::npos || (text.size() - bar - 1) % 2 != 0)
    throw CheckpointError(path + ": bad rank random state in header");
  std::istringstream rng(text.substr(0, bar));
  rng >> rng_;
  if (!rng) throw CheckpointError(path + ": bad sampler RNG state in header");
  const std::string hex = text.substr(bar + 1);
  torch::Tensor state = torch::empty({static_cast<int64_t>(hex.size() / 2)}, torch::kUInt8);
  auto nibble = [&](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    throw CheckpointError(path + ": bad torch generator state in header");
  };
  for (int64_t i = 0; i < state.numel(); ++i)
    state[i] = static_cast<uint8_t>(nibble(hex[2 * i]) * 16 + nibble(hex[2 * i + 1]));
  gen_.set_state(state);
}

void Trainer::SaveCheckpoint(const std::string& path) {
  Sync();
  std::vector<std::string> rank_states;
  if (dist_) {
    // Every rank's random state goes into rank 0's file, through the store.
    const std::string key = "msspr/checkpoint/" + std::to_string(step_) + "/rank";
    if (dist_->rank() != 0) {
      dist_->Set(key + std::to_string(dist_->rank()), RandomStateText());
      return;
    }
    rank_states.push_back(RandomStateText());
    for (int r = 1; r < dist_->world_size(); ++r)
      rank_states.push_back(dist_->Get(key + std::to_string(r)));
  }
  const NamedModules named = agent_->CheckpointModules();
  std::vector<torch::nn::Module*> modules;
  for (const auto& [name, m] : named) modules.push_back(m);
  CheckFiniteWeights(modules, step_, "checkpoint " + path);
  CheckpointHeader header;
  header.options = options_;
  header.step = step_;
  header.repr_credit = agent_->schedule_credit();
  std::ostringstream rng;
  rng << rng_;
  header.sampler_rng = rng.str();
  header.rank_states = std::move(rank_states);
  torch::serialize::OutputArchive archive;
  for (const auto& [name, m] : named) WriteModule(archive, name, *m);
  for (const auto& [name, opt] : agent_->Optimizers()) {
    torch::serialize::OutputArchive sub;
    opt->save(sub);
    archive.write(name, sub);
  }
  archive.write("torch_generator", gen_.get_state());
  WriteArchiveFile(path, "trainer", CheckpointHeaderToYaml(header), archive,
                   /*keep_previous=*/true);
}

void Trainer::LoadCheckpoint(const std::string& newest) {
  Sync();
  std::string path;  // newest, or newest.prev when newest fails its CRC
  const CheckpointFile file = ReadCheckpointFileOrPrevious(newest, "trainer", &path);
  const CheckpointHeader header = ParseCheckpointHeader(file.header, path);
  if (NetworkYaml(header.options) != NetworkYaml(options_)) {
    throw CheckpointError(
        path + ": network or baseline options differ from this trainer's (agent '" +
        header.options.baseline.agent + "' in the file, '" + options_.baseline.agent + "' here)");
  }
  if ((header.options.trainer.policy_ema > 0) != (options_.trainer.policy_ema > 0)) {
    throw CheckpointError(
        path + ": trainer.policy_ema is " + std::to_string(header.options.trainer.policy_ema) +
        " in the file and " + std::to_string(options_.trainer.policy_ema) +
        " here (a run keeps or lacks the policy's moving average from its start)");
  }
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(file.payload.data(), file.payload.size(), device_);
    for (const auto& [name, m] : agent_->CheckpointModules()) ReadModule(archive, name, *m);
    for (const auto& [name, opt] : agent_->Optimizers()) {
      torch::serialize::InputArchive sub;
      archive.read(name, sub);
      opt->load(sub);
    }
    torch::Tensor gen_state;
    archive.read("torch_generator", gen_state);
    gen_.set_state(gen_state.to(torch::kCPU));
  } catch (const c10::Error& e) {
    throw CheckpointError(path + ": cannot restore training state: " + e.what_without_backtrace());
  }
  std::istringstream rng(header.sampler_rng);
  rng >> rng_;
  if (!rng) throw CheckpointError(path + ": bad sampler RNG state in header");
  if (dist_) {
    const int world = dist_->world_size();
    if (static_cast<int>(header.rank_states.size()) != world) {
      throw CheckpointError(path + ": written by a group of " +
                            std::to_string(header.rank_states.size()) + " rank(s), resumed by " +
                            std::to_string(world) + " (resume with the same world size)");
    }
    RestoreRandomState(header.rank_states[dist_->rank()], path);
  } else if (!header.rank_states.empty()) {
    throw CheckpointError(
        path + ": written by a group of " + std::to_string(header.rank_states.size()) +
        " ranks; resume it with --world-size " + std::to_string(header.rank_states.size()));
  }
  step_ = header.step;
  agent_->set_schedule_credit(header.repr_credit);
}

void Trainer::ExportPolicy(const std::string& path, bool raw) {
  Sync();
  // The moving average when there is one: what MakePolicy() evaluates.
  std::vector<torch::nn::Module*> modules;
  std::vector<std::pair<std::string, const torch::nn::Module*>> named;
  for (const auto& [name, m] : agent_->PolicyModules(raw)) {
    modules.push_back(m);
    named.emplace_back(name, m);
  }
  CheckFiniteWeights(modules, step_, "policy export " + path);
  WritePolicyExport(path, options_, step_, named);
}

MsprOptions ReadCheckpointOptions(const std::string& newest) {
  std::string path;
  const CheckpointFile file = ReadCheckpointFileOrPrevious(newest, "", &path);
  return ParseCheckpointHeader(file.header, path).options;
}

}  // namespace core
}  // namespace msspr
