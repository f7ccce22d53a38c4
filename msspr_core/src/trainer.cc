// The trainer: construction of the networks and optimisers, data-parallel
// set-up, the baseline agents' step, the updates of Ms.PR's networks, target
// copies and the policy's moving average. The batch builder, the losses, the
// step schedules, the loop and checkpoint I/O are in trainer_*.cc and
// mspr_losses.cc.
#include "msspr_core/trainer.h"

#include <ATen/Parallel.h>
#include <ATen/autocast_mode.h>
#include <sys/stat.h>
#include <torch/version.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "async_worker.h"
#include "module_io.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/foreach_adamw.h"
#include "msspr_core/progress.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

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

std::vector<std::pair<std::string, double>> LossInfo::Named() const {
  if (!agent.empty()) return agent;
  return {{"repr", repr},     {"dyn", dyn},       {"rew", rew},       {"inv", inv},
          {"gdyn", goal_dyn}, {"gact", goal_act}, {"critic", critic}, {"q", q_mean},
          {"actor", actor},   {"bc", bc}};
}

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
  if (options_.baseline.agent != "mspr") {
    agent_ = MakeAgent(options_);
    agent_->to(device_);
    // OGBench: one Adam (no weight decay) over all the agent's parameters.
    agent_opt_ = std::make_unique<torch::optim::Adam>(
        agent_->TrainableParameters(), torch::optim::AdamOptions(options_.baseline.lr));
    return;
  }
  repr_ = Representation(n);
  critic_ = Critic(n);
  actor_ = Actor(n);
  target_repr_ = Representation(n);
  target_critic_ = Critic(n);
  target_actor_ = Actor(n);
  for (torch::nn::Module* m :
       std::vector<torch::nn::Module*>{repr_.get(), critic_.get(), actor_.get(), target_repr_.get(),
                                       target_critic_.get(), target_actor_.get()}) {
    m->to(device_);
  }
  UpdateTargets();
  SetRequiresGrad(*target_repr_, false);
  SetRequiresGrad(*target_critic_, false);
  SetRequiresGrad(*target_actor_, false);
  if (options_.trainer.policy_ema > 0) {
    ema_repr_ = Representation(n);
    ema_critic_ = Critic(n);
    ema_actor_ = Actor(n);
    for (torch::nn::Module* m :
         std::vector<torch::nn::Module*>{ema_repr_.get(), ema_critic_.get(), ema_actor_.get()}) {
      m->to(device_);
      SetRequiresGrad(*m, false);
    }
    HardUpdate(*ema_repr_, *repr_);
    HardUpdate(*ema_critic_, *critic_);
    HardUpdate(*ema_actor_, *actor_);
  }
  const RepresentationOptions& r = options_.representation;
  const AgentOptions& a = options_.agent;
  // Multi-tensor AdamW: the same maths and state as torch::optim::AdamW.
  repr_opt_ = std::make_unique<ForeachAdamW>(
      repr_->parameters(), torch::optim::AdamWOptions(r.lr).weight_decay(r.weight_decay));
  critic_opt_ = std::make_unique<ForeachAdamW>(
      critic_->parameters(), torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
  actor_opt_ = std::make_unique<ForeachAdamW>(
      actor_->parameters(), torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
  bins_ = ReturnBins(n.num_bins, a.gamma).to(device_);
}

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
  // Each rank's own streams: batches and target-policy noise.
  std::seed_seq seq{static_cast<uint32_t>(options_.trainer.seed),
                    static_cast<uint32_t>(options_.trainer.seed >> 32), static_cast<uint32_t>(rank),
                    0x6d737072u};
  rng_.seed(seq);
  gen_ = at::make_generator<at::CPUGeneratorImpl>(options_.trainer.seed * 1000003ULL +
                                                  static_cast<uint64_t>(rank));
  // Identical starting weights (targets included) on every rank.
  std::vector<torch::Tensor> tensors;
  for (const auto& [name, m] : CheckpointModules()) {
    for (const auto& p : m->parameters()) tensors.push_back(p.detach());
    for (const auto& b : m->buffers()) tensors.push_back(b);
  }
  torch::NoGradGuard no_grad;
  dist_->Broadcast(tensors, 0);
}

void Trainer::ReduceGrads(torch::nn::Module& module) {
  if (dist_) dist_->AverageGradients(module.parameters());
}

LossInfo Trainer::BaselineStep(bool collect_info) {
  ++step_;
  LossInfo info;
  NamedValues named;
  const TransitionBatch batch = SampleBaselineBatch();
  const torch::Tensor loss = agent_->Loss(batch, collect_info ? &named : nullptr);
  agent_opt_->zero_grad();
  loss.backward();
  if (dist_) dist_->AverageGradients(agent_opt_->parameters());
  agent_opt_->step();
  agent_->UpdateTargets();
  if (collect_info) info.agent = std::move(named);
  return info;
}

LossInfo Trainer::EmptyLossInfo() const {
  LossInfo info;
  if (agent_) {
    for (const std::string& name : agent_->LossNames()) info.agent.emplace_back(name, NAN);
  }
  return info;
}

std::vector<std::pair<std::string, torch::nn::Module*>> Trainer::CheckpointModules() {
  if (agent_) return {{"agent", agent_.get()}};
  std::vector<std::pair<std::string, torch::nn::Module*>> modules{
      {"repr", repr_.get()},
      {"critic", critic_.get()},
      {"actor", actor_.get()},
      {"target_repr", target_repr_.get()},
      {"target_critic", target_critic_.get()},
      {"target_actor", target_actor_.get()}};
  if (ema_repr_) {
    modules.emplace_back("ema_repr", ema_repr_.get());
    modules.emplace_back("ema_critic", ema_critic_.get());
    modules.emplace_back("ema_actor", ema_actor_.get());
  }
  return modules;
}

bool Trainer::bf16() const { return options_.trainer.precision == "bf16"; }

void Trainer::RepresentationBackward(const ChunkBatch& batch, LossInfo* info) {
  ClearGrads(*repr_);
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_);
    loss = RepresentationLoss(batch, info);
  }
  loss.backward();
}

void Trainer::UpdateRepresentation(const ChunkBatch& batch, LossInfo* info) {
  Sync();
  RepresentationBackward(batch, info);
  ReduceGrads(*repr_);
  repr_opt_->step();
}

void Trainer::UpdateCritic(const TransitionBatch& batch, const torch::Tensor& noise,
                           LossInfo* info) {
  Sync();
  const bool through = options_.agent.critic_grad_to_encoder;
  if (through) {
    UpdateCritic(batch, nullptr, noise, info);
    return;
  }
  const TransitionLatents lat = EncodeTransitionsForUpdate(batch);
  UpdateCritic(batch, &lat, noise, info);
}

void Trainer::UpdateCritic(const TransitionBatch& batch, const TransitionLatents* lat,
                           const torch::Tensor& noise, LossInfo* info) {
  torch::Tensor y;
  {
    PrecisionScope precision(bf16(), device_);
    y = CriticTarget(batch, noise);
  }
  UpdateCriticFromTarget(batch, lat, y, info);
}

void Trainer::UpdateCriticFromTarget(const TransitionBatch& batch, const TransitionLatents* lat,
                                     const torch::Tensor& y, LossInfo* info) {
  ClearGrads(*critic_);
  const bool through = lat == nullptr;
  if (through) ClearGrads(*repr_);
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_);
    loss = CriticLossFromTarget(batch, lat, y, info);
  }
  loss.backward();
  ReduceGrads(*critic_);
  critic_opt_->step();
  if (through) {
    ReduceGrads(*repr_);
    repr_opt_->step();
  }
}

void Trainer::UpdateActor(const TransitionBatch& batch, LossInfo* info) {
  Sync();
  const TransitionLatents lat = EncodeTransitionsForUpdate(batch);
  UpdateActor(batch, lat, info);
}

void Trainer::UpdateActor(const TransitionBatch& batch, const TransitionLatents& lat,
                          LossInfo* info) {
  // Gradients only for the actor's parameters: the critic and E_sa are
  // differentiated through but not updated by the actor loss.
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_);
    loss = ActorLoss(batch, lat, info);
  }
  std::vector<torch::Tensor> params = actor_->parameters();
  std::vector<torch::Tensor> grads = torch::autograd::grad({loss}, params);
  for (size_t i = 0; i < params.size(); ++i) params[i].mutable_grad() = grads[i];
  ReduceGrads(*actor_);
  actor_opt_->step();
}

void Trainer::UpdateTargets() {
  Sync();
  if (agent_) {
    agent_->UpdateTargets();
    return;
  }
  HardUpdate(*target_repr_, *repr_);
  HardUpdate(*target_critic_, *critic_);
  HardUpdate(*target_actor_, *actor_);
}

void Trainer::UpdatePolicyAverage() {
  if (!ema_repr_) return;
  // Warm-up: the plain mean of the weights of steps 0..t until that window is
  // longer than the average's (t > decay / (1 - decay)), so the start's
  // random weights do not linger in it.
  const double t = static_cast<double>(step_);
  const double decay = std::min(options_.trainer.policy_ema, t / (t + 1.0));
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> avg, raw;
  const std::vector<std::pair<torch::nn::Module*, torch::nn::Module*>> pairs{
      {ema_repr_.get(), repr_.get()},
      {ema_critic_.get(), critic_.get()},
      {ema_actor_.get(), actor_.get()}};
  for (const auto& [e, o] : pairs) {
    for (const auto& p : e->parameters()) avg.push_back(p);
    for (const auto& p : o->parameters()) raw.push_back(p.detach());
    const auto eb = e->buffers();
    const auto ob = o->buffers();
    for (size_t i = 0; i < eb.size(); ++i) eb[i].copy_(ob[i]);
  }
  TORCH_CHECK(avg.size() == raw.size(), "UpdatePolicyAverage: parameter count mismatch");
  torch::_foreach_mul_(avg, decay);
  torch::_foreach_add_(avg, raw, 1.0 - decay);
}

Policy Trainer::MakePolicy() {
  Sync();
  if (agent_) return Policy(options_, agent_, device_);
  if (ema_repr_) return Policy(options_, ema_repr_, ema_actor_, ema_critic_, device_);
  return Policy(options_, repr_, actor_, critic_, device_);
}

// --- Ms.PR's losses on the trainer's networks (mspr_losses.h) ---------------

Trainer::TransitionLatents Trainer::EncodeTransitions(const TransitionBatch& batch) {
  Sync();
  return Encode(batch);
}

Trainer::TransitionLatents Trainer::Encode(const TransitionBatch& batch) {
  return mspr::EncodeTransitions(*repr_, batch);
}

Trainer::TransitionLatents Trainer::EncodeTransitionsForUpdate(const TransitionBatch& batch) {
  PrecisionScope precision(bf16(), device_);
  return Encode(batch);
}

torch::Tensor Trainer::RepresentationLoss(const ChunkBatch& batch, LossInfo* info) {
  return mspr::RepresentationLoss(options_, *repr_, *target_repr_, bins_, batch, info);
}

torch::Tensor Trainer::CriticLoss(const TransitionBatch& batch, const torch::Tensor& noise,
                                  LossInfo* info) {
  if (options_.agent.critic_grad_to_encoder && torch::GradMode::is_enabled()) {
    return CriticLoss(batch, nullptr, noise, info);
  }
  const TransitionLatents lat = EncodeTransitions(batch);
  return CriticLoss(batch, &lat, noise, info);
}

torch::Tensor Trainer::CriticTarget(const TransitionBatch& batch, const torch::Tensor& noise) {
  MsprNetworks target{target_repr_, target_critic_, target_actor_};
  return mspr::CriticTarget(options_.agent, target, batch, noise);
}

torch::Tensor Trainer::CriticLoss(const TransitionBatch& batch, const TransitionLatents* lat,
                                  const torch::Tensor& noise, LossInfo* info) {
  return CriticLossFromTarget(batch, lat, CriticTarget(batch, noise), info);
}

torch::Tensor Trainer::CriticLossFromTarget(const TransitionBatch& batch,
                                            const TransitionLatents* lat, const torch::Tensor& y,
                                            LossInfo* info) {
  MsprNetworks online{repr_, critic_, actor_};
  return mspr::CriticLoss(options_.agent, online, batch, lat, y, info);
}

torch::Tensor Trainer::ActorLoss(const TransitionBatch& batch, LossInfo* info) {
  const TransitionLatents lat = EncodeTransitions(batch);
  return ActorLoss(batch, lat, info);
}

torch::Tensor Trainer::ActorLoss(const TransitionBatch& batch, const TransitionLatents& lat,
                                 LossInfo* info) {
  MsprNetworks online{repr_, critic_, actor_};
  return mspr::ActorLoss(options_.agent, online, batch, lat, info);
}

LossInfo Trainer::ValidationLosses(const Dataset& data, int batch, uint64_t seed) {
  Sync();
  const MsprOptions& o = options_;
  BatchSampler sampler(data, o.relabel, o.agent.gamma, o.agent.n_step, o.representation.horizon,
                       o.network.goal_horizon);
  std::mt19937_64 rng(seed);
  torch::NoGradGuard no_grad;
  LossInfo info;
  if (agent_) {
    agent_->Loss(
        MakeTransitionBatch(sampler.SampleOgbenchTransitions(batch, rng, agent_->SubgoalSteps()),
                            false, &data),
        &info.agent);
    return info;
  }
  RepresentationLoss(MakeChunkBatch(sampler.SampleChunks(batch, rng), false, &data), &info);
  const TransitionBatch tb =
      MakeTransitionBatch(sampler.SampleTransitions(batch, rng), false, &data);
  CriticLoss(tb, torch::zeros({tb.action.size(0), tb.action.size(1)}), &info);
  ActorLoss(tb, &info);
  return info;
}

}  // namespace core
}  // namespace msspr
