// The trainer: construction (options, sampler, the agent), data-parallel
// set-up, the step, validation losses, policies, and the Ms.PR parts that
// forward to its MsprAgent. The batch builder, the loop and checkpoint I/O
// are in trainer_*.cc; the agents in gc_agent.cc, mspr_*.cc and
// baselines.cc.
#include "msspr_core/trainer.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <stdexcept>

namespace msspr {
namespace core {

namespace {

// glibc serves blocks over 128 KiB-32 MiB (its adaptive threshold) with
// mmap and returns them on free, so every step's activations are fresh pages
// that the kernel zero-fills: measured, half of a CPU-scale step (132 ms ->
// 69 ms in bf16 at 1 thread). Keep freed memory in the heap instead. The
// process's resident memory stays at its peak, which the trainer reaches in
// its first steps anyway. Process-wide; done once.
void KeepFreedMemoryInHeap() {
#if defined(__GLIBC__)
  static const bool done = [] {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's maximum
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    return true;
  }();
  (void)done;
#endif
}

}  // namespace

Trainer::Trainer(const MsprOptions& options, std::shared_ptr<const Dataset> data)
    : options_(options),
      data_(std::move(data)),
      device_(options.trainer.device),
      rng_(options.trainer.seed),
      gen_(at::make_generator<at::CPUGeneratorImpl>(options.trainer.seed)) {
  if (!data_) throw OptionsError("Trainer: no dataset");
  KeepFreedMemoryInHeap();
  NetworkOptions& n = options_.network;
  if (n.action_dim == 0) n.action_dim = data_->action_dim();
  if (n.obs_mode == "state" && n.obs_dim == 0) n.obs_dim = data_->obs_dim();
  if (n.obs_mode == "pixels" && data_->has_images()) {
    n.image_height = data_->image_shape().height;
    n.image_width = data_->image_shape().width;
    n.image_channels = data_->image_shape().channels;
  }
  ValidateOptions(options_);
  if (n.action_dim != data_->action_dim()) {
    throw OptionsError("network.action_dim " + std::to_string(n.action_dim) +
                       " != dataset action_dim " + std::to_string(data_->action_dim()));
  }
  if (n.obs_mode == "state" && n.obs_dim != data_->obs_dim()) {
    throw OptionsError("network.obs_dim " + std::to_string(n.obs_dim) + " != dataset obs_dim " +
                       std::to_string(data_->obs_dim()));
  }
  if (n.obs_mode == "pixels" && !data_->has_images()) {
    throw OptionsError("network.obs_mode is 'pixels' but the dataset has no images");
  }
  sampler_ = std::make_unique<BatchSampler>(*data_, options_.relabel, options_.agent.gamma,
                                            options_.agent.n_step, options_.representation.horizon,
                                            n.goal_horizon);
  torch::manual_seed(options_.trainer.seed);
  agent_ = MakeGcAgent(options_, device_, /*training=*/true);
}

Trainer::~Trainer() = default;

int Trainer::local_batch() const {
  return dist_ ? options_.trainer.batch_size / dist_->world_size() : options_.trainer.batch_size;
}

void Trainer::SetDistributed(std::shared_ptr<Distributed> dist) {
  Sync();
  if (!dist) return;
  const int world = dist->world_size(), rank = dist->rank();
  if (options_.trainer.batch_size % world != 0) {
    throw OptionsError("trainer.batch_size " + std::to_string(options_.trainer.batch_size) +
                       " is not a multiple of the world size " + std::to_string(world));
  }
  dist_ = std::move(dist);
  agent_->SetDistributed(dist_);
  // Each rank's own streams: batches and target-policy noise.
  std::seed_seq seq{static_cast<uint32_t>(options_.trainer.seed),
                    static_cast<uint32_t>(options_.trainer.seed >> 32), static_cast<uint32_t>(rank),
                    0x6d737072u};
  rng_.seed(seq);
  gen_ = at::make_generator<at::CPUGeneratorImpl>(options_.trainer.seed * 1000003ULL +
                                                  static_cast<uint64_t>(rank));
  // Identical starting weights (targets included) on every rank.
  std::vector<torch::Tensor> tensors;
  for (const auto& [name, m] : agent_->CheckpointModules()) {
    for (const auto& p : m->parameters()) tensors.push_back(p.detach());
    for (const auto& b : m->buffers()) tensors.push_back(b);
  }
  torch::NoGradGuard no_grad;
  dist_->Broadcast(tensors, 0);
}

// The training batches, step count and noise an agent's step draws.
class Trainer::Batches : public TrainingContext {
 public:
  explicit Batches(Trainer& t) : t_(t) {}
  ChunkBatch SampleChunks() override { return t_.SampleChunks(); }
  TransitionBatch SampleTransitions() override { return t_.SampleTransitions(); }
  TransitionBatch SampleOgbenchTransitions(int subgoal_steps) override {
    // Pixels: representation.augment_prob's random shifts, as Ms.PR's batches get them.
    return t_.MakeTransitionBatch(
        t_.sampler_->SampleOgbenchTransitions(t_.local_batch(), t_.rng_, subgoal_steps),
        t_.options_.network.obs_mode == "pixels");
  }
  int64_t step() const override { return t_.step_; }
  torch::Tensor Noise(int64_t rows, int64_t cols) override {
    return torch::randn({rows, cols}, t_.gen_, torch::kFloat32);
  }

 private:
  Trainer& t_;
};

// Batches of another dataset, without augmentation, from a seeded stream.
class Trainer::ValidationBatches : public BatchSource {
 public:
  ValidationBatches(Trainer& t, const Dataset& data, int batch, uint64_t seed)
      : t_(t),
        data_(data),
        batch_(batch),
        sampler_(data, t.options_.relabel, t.options_.agent.gamma, t.options_.agent.n_step,
                 t.options_.representation.horizon, t.options_.network.goal_horizon),
        rng_(seed) {}
  ChunkBatch SampleChunks() override {
    return t_.MakeChunkBatch(sampler_.SampleChunks(batch_, rng_), false, &data_);
  }
  TransitionBatch SampleTransitions() override {
    return t_.MakeTransitionBatch(
        sampler_.SampleTransitions(batch_, rng_, t_.options_.agent.subgoal_steps), false, &data_);
  }
  TransitionBatch SampleOgbenchTransitions(int subgoal_steps) override {
    return t_.MakeTransitionBatch(sampler_.SampleOgbenchTransitions(batch_, rng_, subgoal_steps),
                                  false, &data_);
  }

 private:
  Trainer& t_;
  const Dataset& data_;
  int batch_;
  BatchSampler sampler_;
  std::mt19937_64 rng_;
};

LossInfo Trainer::Step(bool collect_info) {
  ++step_;
  Batches batches(*this);
  return agent_->Step(batches, collect_info);
}

LossInfo Trainer::ValidationLosses(const Dataset& data, int batch, uint64_t seed) {
  Sync();
  ValidationBatches batches(*this, data, batch, seed);
  torch::NoGradGuard no_grad;
  return agent_->ValidationLosses(batches);
}

TransitionBatch Trainer::SampleBaselineBatch() {
  const std::shared_ptr<OgbenchAgent> a = agent();
  if (!a) throw std::logic_error("Trainer::SampleBaselineBatch: Ms.PR takes no OGBench batches");
  return Batches(*this).SampleOgbenchTransitions(a->SubgoalSteps());
}

std::shared_ptr<OgbenchAgent> Trainer::agent() {
  Sync();
  return std::dynamic_pointer_cast<OgbenchAgent>(agent_);
}

void Trainer::UpdateTargets() {
  Sync();
  agent_->UpdateTargets();
}

Policy Trainer::MakePolicy() {
  Sync();
  return Policy(options_, agent_, device_);
}

// --- Ms.PR's parts --------------------------------------------------------------------

MsprAgent& Trainer::mspr() {
  Sync();
  auto* m = dynamic_cast<MsprAgent*>(agent_.get());
  if (!m)
    throw std::logic_error("Trainer: the " + options_.baseline.agent +
                           " agent has no Ms.PR networks or losses");
  return *m;
}

torch::Tensor Trainer::RepresentationLoss(const ChunkBatch& batch, LossInfo* info) {
  return mspr().RepresentationLoss(batch, info);
}

torch::Tensor Trainer::CriticLoss(const TransitionBatch& batch, const torch::Tensor& noise,
                                  LossInfo* info) {
  return mspr().CriticLoss(batch, noise, info);
}

torch::Tensor Trainer::ActorLoss(const TransitionBatch& batch, LossInfo* info) {
  return mspr().ActorLoss(batch, info);
}

Trainer::TransitionLatents Trainer::EncodeTransitions(const TransitionBatch& batch) {
  return mspr().EncodeTransitions(batch);
}

void Trainer::UpdateRepresentation(const ChunkBatch& batch, LossInfo* info) {
  mspr().UpdateRepresentation(batch, info);
}

void Trainer::UpdateCritic(const TransitionBatch& batch, const torch::Tensor& noise,
                           LossInfo* info) {
  mspr().UpdateCritic(batch, noise, info);
}

void Trainer::UpdateActor(const TransitionBatch& batch, LossInfo* info) {
  mspr().UpdateActor(batch, info);
}

void Trainer::UpdatePolicyAverage() {
  auto* m = dynamic_cast<MsprAgent*>(agent_.get());
  if (m) m->UpdatePolicyAverage(step_);
}

}  // namespace core
}  // namespace msspr
