#include "msspr_core/trainer.h"

#include <ATen/Parallel.h>
#include <ATen/autocast_mode.h>
#include <torch/version.h>
#include <sys/stat.h>
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
#include "msspr_core/checkpoint.h"
#include "msspr_core/foreach_adamw.h"
#include "msspr_core/progress.h"
#include "module_io.h"

#include <sstream>

namespace msspr {
namespace core {
namespace {

// Sets gradients to undefined so that optimisers skip parameters that the
// next backward does not reach.
void ClearGrads(torch::nn::Module& m) {
  for (auto& p : m.parameters()) p.mutable_grad() = torch::Tensor();
}

torch::Tensor Huber(const torch::Tensor& diff, double delta) {
  const torch::Tensor a = diff.abs();
  return torch::where(a <= delta, 0.5 * diff * diff, delta * (a - 0.5 * delta));
}

// Random shift (DrQ): replicate-pad by `pad` and crop back, in place on
// one uint8 HWC image.
void ShiftImage(uint8_t* img, int h, int w, int c, int dy, int dx, std::vector<uint8_t>* scratch) {
  scratch->assign(img, img + int64_t{h} * w * c);
  const uint8_t* src = scratch->data();
  for (int y = 0; y < h; ++y) {
    const int sy = std::clamp(y + dy, 0, h - 1);
    for (int x = 0; x < w; ++x) {
      const int sx = std::clamp(x + dx, 0, w - 1);
      std::memcpy(img + (int64_t{y} * w + x) * c, src + (int64_t{sy} * w + sx) * c, c);
    }
  }
}

void ShiftSampleImages(const std::vector<std::pair<int, int>>& shifts,
                       const std::vector<torch::Tensor*>& images) {
  // images: tensors of [B * n, H, W, C] uint8, the n images of sample k in
  // rows k * n .. k * n + n - 1; each gets sample k's shift.
  if (shifts.empty()) return;
  const int64_t b = static_cast<int64_t>(shifts.size());
  std::vector<uint8_t> scratch;
  for (torch::Tensor* t : images) {
    TORCH_CHECK(t->dim() == 4 && t->scalar_type() == torch::kUInt8 && t->is_contiguous() &&
                    t->size(0) % b == 0,
                "ShiftSampleImages: expects contiguous uint8 [B * n, H, W, C] images");
    const int64_t per_sample = t->size(0) / b;  // the sample's images are consecutive rows
    const int h = t->size(1), w = t->size(2), c = t->size(3);
    const int64_t stride = int64_t{h} * w * c;
    uint8_t* data = t->data_ptr<uint8_t>();
    for (int64_t k = 0; k < b; ++k) {
      const auto [dy, dx] = shifts[k];
      if (dy == 0 && dx == 0) continue;
      for (int64_t j = 0; j < per_sample; ++j) {
        ShiftImage(data + (k * per_sample + j) * stride, h, w, c, dy, dx, &scratch);
      }
    }
  }
}

// Per-step masked means summed over the steps: values and mask [H, B] -> [].
torch::Tensor SumOfMaskedMeans(const torch::Tensor& values, const torch::Tensor& mask) {
  return ((values * mask).sum(1) / mask.sum(1).clamp_min(1.0)).sum();
}

// trainer.precision = bf16: matrix products and convolutions run in
// bfloat16 inside this scope (autocast); backward runs outside it, as
// PyTorch recommends. A no-op for fp32.
class PrecisionScope {
 public:
  PrecisionScope(bool bf16, const torch::Device& device)
      : bf16_(bf16), type_(device.is_cuda() ? at::kCUDA : at::kCPU) {
    if (!bf16_) return;
    prev_ = Enabled(type_);
    SetDtype(type_, at::kBFloat16);
    SetEnabled(type_, true);
  }
  ~PrecisionScope() {
    if (!bf16_) return;
    SetEnabled(type_, prev_);
    at::autocast::clear_cache();
  }
  PrecisionScope(const PrecisionScope&) = delete;
  PrecisionScope& operator=(const PrecisionScope&) = delete;

 private:
  // LibTorch 2.4 replaced the per-device functions by ones taking the device
  // type (the old ones warn on every call there).
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
  static bool Enabled(at::DeviceType t) { return at::autocast::is_autocast_enabled(t); }
  static void SetEnabled(at::DeviceType t, bool on) { at::autocast::set_autocast_enabled(t, on); }
  static void SetDtype(at::DeviceType t, at::ScalarType d) { at::autocast::set_autocast_dtype(t, d); }
#else
  static bool Enabled(at::DeviceType t) {
    return t == at::kCUDA ? at::autocast::is_enabled() : at::autocast::is_cpu_enabled();
  }
  static void SetEnabled(at::DeviceType t, bool on) {
    if (t == at::kCUDA) at::autocast::set_enabled(on);
    else at::autocast::set_cpu_enabled(on);
  }
  static void SetDtype(at::DeviceType t, at::ScalarType d) {
    if (t == at::kCUDA) at::autocast::set_autocast_gpu_dtype(d);
    else at::autocast::set_autocast_cpu_dtype(d);
  }
#endif
  bool bf16_;
  at::DeviceType type_;
  bool prev_ = false;
};

torch::Tensor F32(const torch::Tensor& t) { return t.to(torch::kFloat32); }

}  // namespace
}  // namespace core
}  // namespace msspr

// The OpenMP runtime that LibTorch loaded (weak: null without one). Its
// thread count is per calling thread, unlike at::set_num_threads, which is
// process-wide and also drops oneDNN's cached convolution primitives.
extern "C" {
__attribute__((weak)) void omp_set_num_threads(int);
__attribute__((weak)) int omp_get_max_threads(void);
}

namespace msspr {
namespace core {
namespace {

// Sets the calling thread's intra-op thread count for a scope (no-op for
// n <= 0 or without OpenMP).
class ThreadCountScope {
 public:
  explicit ThreadCountScope(int n) {
    if (n <= 0 || omp_set_num_threads == nullptr || omp_get_max_threads == nullptr) return;
    prev_ = omp_get_max_threads();
    if (prev_ != n) omp_set_num_threads(n);
    else prev_ = 0;
  }
  ~ThreadCountScope() {
    if (prev_ > 0) omp_set_num_threads(prev_);
  }
  ThreadCountScope(const ThreadCountScope&) = delete;
  ThreadCountScope& operator=(const ThreadCountScope&) = delete;

 private:
  int prev_ = 0;
};

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

void MakeDirs(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create directory: " + ec.message());
}

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

// Losses read back on a logged step; the representation terms count only when
// a representation update ran in that step (they are NaN by design otherwise).
void CheckFiniteLosses(const LossInfo& info, bool repr_updated, int64_t step) {
  std::string bad;
  for (const auto& [name, v] : info.Named()) {
    const bool repr_term = name != "critic" && name != "q" && name != "actor" && name != "bc";
    if (!std::isfinite(v) && (repr_updated || !repr_term))
      bad += " " + name + "=" + std::to_string(v);
  }
  if (!bad.empty())
    throw std::runtime_error("training diverged: non-finite loss at step " + std::to_string(step) + ":" +
                             bad + "; stopped without writing a checkpoint (the last good one is kept)");
}

void NotifyEvalWritten(const TrainLoopOptions& loop) {
  if (!loop.on_eval_written) return;
  try {
    loop.on_eval_written();
  } catch (const std::exception& e) {
    std::cerr << "warning: " << e.what() << " (training goes on)\n";
  }
}

}  // namespace

std::vector<std::pair<std::string, double>> LossInfo::Named() const {
  if (!agent.empty()) return agent;
  return {{"repr", repr},   {"dyn", dyn},           {"rew", rew},       {"inv", inv},
          {"gdyn", goal_dyn}, {"gact", goal_act},   {"critic", critic}, {"q", q_mean},
          {"actor", actor}, {"bc", bc}};
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
    agent_opt_ = std::make_unique<torch::optim::Adam>(agent_->TrainableParameters(),
                                                      torch::optim::AdamOptions(options_.baseline.lr));
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
    for (torch::nn::Module* m : std::vector<torch::nn::Module*>{ema_repr_.get(), ema_critic_.get(), ema_actor_.get()}) {
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

torch::Tensor Trainer::ToDevice(const torch::Tensor& cpu) const {
  return device_.is_cpu() ? cpu : cpu.to(device_, /*non_blocking=*/false);
}

torch::Tensor Trainer::GatherObs(const Dataset& data, const std::vector<int64_t>& idx) const {
  const int64_t n = static_cast<int64_t>(idx.size());
  const NetworkOptions& o = options_.network;
  if (o.obs_mode == "state") {
    torch::Tensor t = torch::empty({n, o.obs_dim}, torch::kFloat32);
    data.GatherStates(idx.data(), n, t.data_ptr<float>());
    return t;
  }
  const int c = o.image_channels * o.frame_stack;
  torch::Tensor t = torch::empty({n, o.image_height, o.image_width, c}, torch::kUInt8);
  data.GatherImages(idx.data(), n, o.frame_stack, t.data_ptr<uint8_t>());
  return t;
}

std::vector<std::pair<int, int>> Trainer::DrawShifts(int64_t batch) {
  // As OGBench: one Bernoulli draw decides for the whole batch, then one
  // random shift per sample.
  const RepresentationOptions& r = options_.representation;
  std::vector<std::pair<int, int>> shifts;
  if (options_.network.obs_mode != "pixels" || r.augment_prob <= 0) return shifts;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng_) >= r.augment_prob) return shifts;
  std::uniform_int_distribution<int> shift(-r.augment_pad, r.augment_pad);
  shifts.resize(batch);
  for (auto& s : shifts) {
    s.first = shift(rng_);
    s.second = shift(rng_);
  }
  return shifts;
}


TransitionBatch Trainer::MakeTransitionBatch(const TransitionIndices& idx, bool augment,
                                             const Dataset* data) {
  const Dataset& d = data ? *data : *data_;
  const int64_t b = static_cast<int64_t>(idx.idx.size());
  torch::Tensor obs = GatherObs(d, idx.idx), next_obs = GatherObs(d, idx.next_idx);
  torch::Tensor value_goal = GatherObs(d, idx.value_goal), actor_goal = GatherObs(d, idx.actor_goal);
  if (augment) {
    // One shift per sample, shared by its observation, next observation and goals.
    ShiftSampleImages(DrawShifts(b), {&obs, &next_obs, &value_goal, &actor_goal});
  }
  TransitionBatch batch;
  batch.obs = ToDevice(obs);
  batch.next_obs = ToDevice(next_obs);
  batch.value_goal = ToDevice(value_goal);
  batch.actor_goal = ToDevice(actor_goal);
  torch::Tensor act = torch::empty({b, d.action_dim()}, torch::kFloat32);
  d.GatherActions(idx.idx.data(), b, act.data_ptr<float>());
  batch.action = ToDevice(act);
  batch.ret = ToDevice(torch::from_blob(const_cast<float*>(idx.ret.data()), {b}, torch::kFloat32).clone());
  batch.discount =
      ToDevice(torch::from_blob(const_cast<float*>(idx.discount.data()), {b}, torch::kFloat32).clone());
  if (!idx.low_goal.empty()) {
    batch.low_goal = ToDevice(GatherObs(d, idx.low_goal));
    batch.high_goal = ToDevice(GatherObs(d, idx.high_goal));
    batch.high_target = ToDevice(GatherObs(d, idx.high_target));
  }
  return batch;
}

ChunkBatch Trainer::MakeChunkBatch(const ChunkIndices& idx, bool augment, const Dataset* data) {
  const Dataset& d = data ? *data : *data_;
  const int64_t b = idx.batch, l = idx.num_states, a = idx.num_actions;
  ChunkBatch batch;
  torch::Tensor states = GatherObs(d, idx.states);  // [B * L, ...], sample-major
  torch::Tensor goal = GatherObs(d, idx.goal);      // [B, ...]
  if (augment) ShiftSampleImages(DrawShifts(b), {&states, &goal});
  std::vector<int64_t> shape{b, l};
  for (int64_t j = 1; j < states.dim(); ++j) shape.push_back(states.size(j));
  batch.states = ToDevice(states.view(shape));
  batch.state_mask = ToDevice(
      torch::from_blob(const_cast<float*>(idx.state_mask.data()), {b, l}, torch::kFloat32).clone());
  torch::Tensor act = torch::empty({b * a, d.action_dim()}, torch::kFloat32);
  d.GatherActions(idx.actions.data(), b * a, act.data_ptr<float>());
  batch.actions = ToDevice(act.view({b, a, d.action_dim()}));
  batch.action_mask = ToDevice(
      torch::from_blob(const_cast<float*>(idx.action_mask.data()), {b, a}, torch::kFloat32).clone());
  batch.goal = ToDevice(goal);
  batch.mc_return = ToDevice(
      torch::from_blob(const_cast<float*>(idx.mc_return.data()), {b, idx.horizon}, torch::kFloat32)
          .clone());
  return batch;
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
  std::seed_seq seq{static_cast<uint32_t>(options_.trainer.seed), static_cast<uint32_t>(options_.trainer.seed >> 32),
                    static_cast<uint32_t>(rank), 0x6d737072u};
  rng_.seed(seq);
  gen_ = at::make_generator<at::CPUGeneratorImpl>(options_.trainer.seed * 1000003ULL + static_cast<uint64_t>(rank));
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

TransitionBatch Trainer::SampleBaselineBatch() {
  return MakeTransitionBatch(
      sampler_->SampleOgbenchTransitions(local_batch(), rng_, agent_->SubgoalSteps()), false);
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
  std::vector<std::pair<std::string, torch::nn::Module*>> modules{{"repr", repr_.get()},
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

TransitionBatch Trainer::SampleTransitions() {
  const bool augment = options_.network.obs_mode == "pixels";
  return MakeTransitionBatch(sampler_->SampleTransitions(local_batch(), rng_), augment);
}

ChunkBatch Trainer::SampleChunks() {
  const bool augment = options_.network.obs_mode == "pixels";
  return MakeChunkBatch(sampler_->SampleChunks(local_batch(), rng_), augment);
}

bool Trainer::bf16() const { return options_.trainer.precision == "bf16"; }

namespace {
// Whether an accumulated representation credit calls for an update.
bool CreditDue(double credit) { return credit >= 1.0 - 1e-9; }
}  // namespace

bool Trainer::ReprUpdateDue(double extra_credit) const {
  return CreditDue(repr_credit_ + extra_credit);
}

torch::Tensor Trainer::RepresentationLoss(const ChunkBatch& batch, LossInfo* info) {
  const RepresentationOptions& r = options_.representation;
  const int64_t k = options_.network.goal_horizon;
  const int64_t b = batch.states.size(0), l = batch.states.size(1);
  const int64_t horizon = batch.mc_return.size(1);
  auto& pred = repr_->predictors;
  // Terms with weight 0 (the ablations D, DI, DIR) are not computed; the goal
  // head is only needed by the reward and goal-level terms.
  const bool use_rew = r.weight_rew != 0, use_inv = r.weight_inv != 0;
  const bool use_gdyn = r.weight_goal_dyn != 0, use_gact = r.weight_goal_act != 0;
  const bool use_goal = use_rew || use_gdyn || use_gact;

  torch::Tensor targets;  // [B, L - 1, zs] target-encoder latents of s_1..s_{L-1}
  {
    torch::NoGradGuard no_grad;
    targets = F32(target_repr_->state_encoder->forward(batch.states.narrow(1, 1, l - 1).flatten(0, 1)))
                  .view({b, l - 1, -1});
  }
  // One encoder call for the chunk's first state and the goal.
  torch::Tensor z, zg;
  if (use_goal) {
    const torch::Tensor both =
        repr_->state_encoder->forward(torch::cat({batch.states.select(1, 0), batch.goal}, 0));
    z = both.narrow(0, 0, b);
    zg = both.narrow(0, b, b);
  } else {
    z = repr_->state_encoder->forward(batch.states.select(1, 0));
  }
  // The latent unroll is sequential: z^{h+1} = f_dyn(E_sa(z^h, a_h)).
  // Everything else is computed for all h at once on [H * B] rows.
  std::vector<torch::Tensor> zs_list{z}, zsa_list;
  for (int64_t h = 0; h < horizon; ++h) {
    zsa_list.push_back(repr_->Zsa(zs_list.back(), batch.actions.select(1, h)));
    zs_list.push_back(pred->Dynamics(zsa_list.back()));
  }
  const torch::Tensor z_h = torch::cat(std::vector<torch::Tensor>(zs_list.begin(), zs_list.end() - 1), 0);  // [H*B, zs]
  const torch::Tensor z_next = F32(torch::cat(std::vector<torch::Tensor>(zs_list.begin() + 1, zs_list.end()), 0));
  const torch::Tensor mask = batch.action_mask.narrow(1, 0, horizon).t();  // [H, B]
  const torch::Tensor target_next = targets.narrow(1, 0, horizon).transpose(0, 1).reshape({horizon * b, -1});

  const auto per_h = [&](const torch::Tensor& v) { return v.view({horizon, b}); };
  const torch::Tensor zero = torch::zeros({}, z_next.options());
  const torch::Tensor dyn = SumOfMaskedMeans(per_h((z_next - target_next).pow(2).mean(-1)), mask);
  torch::Tensor inv = zero, rew = zero, gdyn = zero, gact = zero;
  if (use_inv) {
    const torch::Tensor a_true = batch.actions.narrow(1, 0, horizon).transpose(0, 1).reshape({horizon * b, -1});
    inv = SumOfMaskedMeans(per_h((F32(pred->Inverse(z_h, target_next)) - a_true).pow(2).mean(-1)), mask);
  }
  torch::Tensor grep;
  if (use_goal) grep = repr_->goal_head->forward(z_h, zg.repeat({horizon, 1}));  // [H*B, goal]
  if (use_rew) {
    const torch::Tensor logits = F32(pred->Reward(torch::cat(zsa_list, 0), grep));  // [H*B, bins]
    const torch::Tensor ret = batch.mc_return.t().reshape({horizon * b});
    torch::Tensor per;
    if (r.reward_loss == "mse") {
      per = (TwoHotDecode(logits, bins_) - ret).pow(2);
    } else {
      const torch::Tensor two_hot = TwoHotEncode(ret, bins_, -1.0 / (1.0 - options_.agent.gamma), 0.0);
      per = -(two_hot * torch::log_softmax(logits, -1)).sum(-1);
    }
    rew = SumOfMaskedMeans(per_h(per), mask);
  }
  if (use_gdyn) {
    const torch::Tensor target_k = targets.narrow(1, k - 1, horizon).transpose(0, 1).reshape({horizon * b, -1});
    const torch::Tensor gd_mask = batch.state_mask.narrow(1, k, horizon).t();  // [H, B]
    gdyn = SumOfMaskedMeans(per_h((F32(pred->GoalDynamics(z_h, grep)) - target_k).pow(2).mean(-1)), gd_mask);
  }
  if (use_gact) {
    std::vector<torch::Tensor> windows, masks;
    for (int64_t h = 0; h < horizon; ++h) {
      windows.push_back(batch.actions.narrow(1, h, k));     // [B, k, act]
      masks.push_back(batch.action_mask.narrow(1, h, k));   // [B, k]
    }
    const torch::Tensor ga_true = torch::cat(windows, 0);   // [H*B, k, act]
    const torch::Tensor ga_mask = torch::stack(masks, 0);   // [H, B, k]
    const torch::Tensor err = (F32(pred->GoalActions(z_h, grep)) - ga_true).pow(2).mean(-1).view({horizon, b, k});
    gact = ((err * ga_mask).sum({1, 2}) / ga_mask.sum({1, 2}).clamp_min(1.0)).sum();
  }
  const torch::Tensor total = r.weight_dyn * dyn + r.weight_rew * rew + r.weight_inv * inv +
                              r.weight_goal_dyn * gdyn + r.weight_goal_act * gact;
  if (info) {
    // One device-to-host copy (a sync on GPU) instead of one per term.
    const torch::Tensor host =
        torch::stack({dyn, rew, inv, gdyn, gact, total}).detach().to(torch::kCPU, torch::kFloat64);
    const double* v = host.data_ptr<double>();
    info->dyn = v[0];
    info->rew = v[1];
    info->inv = v[2];
    info->goal_dyn = v[3];
    info->goal_act = v[4];
    info->repr = v[5];
  }
  return total;
}

Trainer::TransitionLatents Trainer::EncodeTransitions(const TransitionBatch& batch) {
  Sync();
  return Encode(batch);
}

Trainer::TransitionLatents Trainer::Encode(const TransitionBatch& batch) {
  // One call of the online encoder over observation, value goal and actor
  // goal (no gradient: actor and critic read the encoders detached).
  torch::NoGradGuard no_grad;
  const int64_t b = batch.obs.size(0);
  const torch::Tensor z =
      repr_->state_encoder->forward(torch::cat({batch.obs, batch.value_goal, batch.actor_goal}, 0));
  TransitionLatents lat;
  lat.zs = z.narrow(0, 0, b);
  lat.z_value_goal = z.narrow(0, b, b);
  lat.z_actor_goal = z.narrow(0, 2 * b, b);
  return lat;
}

Trainer::TransitionLatents Trainer::EncodeTransitionsForUpdate(const TransitionBatch& batch) {
  PrecisionScope precision(bf16(), device_);
  return Encode(batch);
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
  const AgentOptions& a = options_.agent;
  const int64_t b = batch.obs.size(0);
  torch::NoGradGuard no_grad;
  const torch::Tensor z = target_repr_->state_encoder->forward(torch::cat({batch.next_obs, batch.value_goal}, 0));
  const torch::Tensor zs_next = z.narrow(0, 0, b), zg = z.narrow(0, b, b);
  const torch::Tensor grep_next = target_repr_->goal_head->forward(zs_next, zg);
  const torch::Tensor eps =
      (noise.to(device_) * a.target_noise).clamp(-a.target_noise_clip, a.target_noise_clip);
  const torch::Tensor a_next = (F32(target_actor_->forward(zs_next, grep_next)) + eps).clamp(-1.0, 1.0);
  const torch::Tensor q_next = std::get<0>(
      F32(target_critic_->forward(target_repr_->Zsa(zs_next, a_next), grep_next)).min(-1));
  torch::Tensor y = batch.ret + batch.discount * q_next;  // [B]
  if (a.clip_target) y = y.clamp(-1.0 / (1.0 - a.gamma), 0.0);
  return y;
}

torch::Tensor Trainer::CriticLoss(const TransitionBatch& batch, const TransitionLatents* lat,
                                  const torch::Tensor& noise, LossInfo* info) {
  return CriticLossFromTarget(batch, lat, CriticTarget(batch, noise), info);
}

torch::Tensor Trainer::CriticLossFromTarget(const TransitionBatch& batch, const TransitionLatents* lat,
                                            const torch::Tensor& y, LossInfo* info) {
  const AgentOptions& a = options_.agent;
  const int64_t b = batch.obs.size(0);
  torch::Tensor zsa, grep;
  if (lat) {
    torch::NoGradGuard no_grad;
    grep = repr_->goal_head->forward(lat->zs, lat->z_value_goal);
    zsa = repr_->Zsa(lat->zs, batch.action);
  } else {
    // The critic's gradient reaches the encoders (agent.critic_grad_to_encoder).
    const torch::Tensor z = repr_->state_encoder->forward(torch::cat({batch.obs, batch.value_goal}, 0));
    grep = repr_->goal_head->forward(z.narrow(0, 0, b), z.narrow(0, b, b));
    zsa = repr_->Zsa(z.narrow(0, 0, b), batch.action);
  }
  const torch::Tensor q = F32(critic_->forward(zsa, grep));  // [B, 2]
  const torch::Tensor loss = Huber(q - y.unsqueeze(-1), a.huber_delta).mean(0).sum();
  if (info) {
    const torch::Tensor host = torch::stack({loss.detach(), q.detach().mean()}).to(torch::kCPU, torch::kFloat64);
    info->critic = host[0].item<double>();
    info->q_mean = host[1].item<double>();
  }
  return loss;
}

torch::Tensor Trainer::ActorLoss(const TransitionBatch& batch, LossInfo* info) {
  const TransitionLatents lat = EncodeTransitions(batch);
  return ActorLoss(batch, lat, info);
}

torch::Tensor Trainer::ActorLoss(const TransitionBatch& batch, const TransitionLatents& lat,
                                 LossInfo* info) {
  const AgentOptions& a = options_.agent;
  torch::Tensor grep;
  {
    torch::NoGradGuard no_grad;
    grep = repr_->goal_head->forward(lat.zs, lat.z_actor_goal);
  }
  const torch::Tensor pi = F32(actor_->forward(lat.zs, grep));  // [B, act]
  const torch::Tensor q = std::get<0>(F32(critic_->forward(repr_->Zsa(lat.zs, pi), grep)).min(-1));  // [B]
  const torch::Tensor scale = q.abs().mean().detach().clamp_min(1e-6);
  const torch::Tensor q_loss = -q.mean() / scale;
  const torch::Tensor bc = (pi - batch.action).pow(2).sum(-1).mean();
  const torch::Tensor loss = q_loss + a.bc_weight * bc;
  if (info) {
    const torch::Tensor host = torch::stack({loss.detach(), bc.detach()}).to(torch::kCPU, torch::kFloat64);
    info->actor = host[0].item<double>();
    info->bc = host[1].item<double>();
  }
  return loss;
}

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
      {ema_repr_.get(), repr_.get()}, {ema_critic_.get(), critic_.get()}, {ema_actor_.get(), actor_.get()}};
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

bool Trainer::pipelined() const {
  const std::string& p = options_.trainer.pipeline;
  if (p == "off" || !device_.is_cpu() || agent_ || dist_) return false;
  return p == "on" || at::get_num_threads() >= 2;
}

void Trainer::Sync() {
  if (!worker_) return;
  worker_->Wait();
  if (!pending_actor_) return;
  // A deferred actor update (pipelined, critic_grad_to_encoder): run now, on
  // the worker with its thread count, as the next step would have.
  TransitionBatch batch = std::move(*pending_actor_);
  pending_actor_.reset();
  RunOnWorker(pending_threads_, [this, b = std::move(batch)] { UpdateActor(b, EncodeTransitionsForUpdate(b), nullptr); });
  worker_->Wait();
}

void Trainer::RunOnWorker(int threads, std::function<void()> task) {
  if (!worker_) worker_ = std::make_unique<AsyncWorker>();
  worker_->Run([threads, task = std::move(task)] {
    // Torch's per-thread setup first (it sets the thread's count to the
    // process-wide one), then this worker's share.
    at::internal::lazy_init_num_threads();
    const ThreadCountScope scope(threads);
    task();
  });
}

Trainer::~Trainer() {
  if (!worker_) return;
  try {
    worker_->Wait();
  } catch (const std::exception&) {
    // The error of an update nobody waits for any more: the trainer is gone.
  }
}

LossInfo Trainer::Step(bool collect_info) {
  if (agent_) return BaselineStep(collect_info);
  LossInfo info;
  LossInfo* out = collect_info ? &info : nullptr;
  // Pipelined: this thread keeps ceil(n / 2) of torch's n threads for the
  // representation update, the worker gets the rest for the actor-critic one.
  const bool pipe = pipelined();
  const int threads = at::get_num_threads();
  const int worker_threads = std::max(1, threads / 2);
  const ThreadCountScope main_threads(pipe ? std::max(1, threads - threads / 2) : 0);
  if (pipe && options_.agent.critic_grad_to_encoder) return CriticGradPipelinedStep(collect_info, worker_threads);
  ++step_;
  if (step_ % options_.agent.target_update_every == 0) {
    Sync();
    UpdateTargets();
  }
  repr_credit_ += options_.representation.updates_per_step;
  while (ReprUpdateDue()) {
    // The previous step's actor-critic update reads the encoders while this
    // forward and backward run; the optimiser step waits for it.
    RepresentationBackward(SampleChunks(), out);
    Sync();
    ReduceGrads(*repr_);
    repr_opt_->step();
    repr_credit_ -= 1.0;
  }
  TransitionBatch batch = SampleTransitions();
  torch::Tensor noise = torch::randn({batch.action.size(0), batch.action.size(1)}, gen_, torch::kFloat32);
  Sync();
  // Every update so far is done (this step's representation update, the
  // previous step's actor and critic): the average takes them in.
  UpdatePolicyAverage();
  if (options_.agent.critic_grad_to_encoder) {
    // The critic update changes the encoders: the actor re-encodes.
    UpdateCritic(batch, noise, out);
    UpdateActor(batch, out);
    return info;
  }
  // The encoders are not changed by the critic update, so the critic and the
  // actor share one encoding of the batch.
  auto actor_critic = [this](const TransitionBatch& b, const torch::Tensor& n, LossInfo* o) {
    const TransitionLatents lat = EncodeTransitionsForUpdate(b);
    UpdateCritic(b, &lat, n, o);
    UpdateActor(b, lat, o);
  };
  if (pipe && !collect_info) {
    RunOnWorker(worker_threads, [actor_critic, b = std::move(batch), n = std::move(noise)] { actor_critic(b, n, nullptr); });
    return info;
  }
  actor_critic(batch, noise, out);
  return info;
}

// Pipelined with the critic's gradient into the encoders. The critic update
// writes the encoders, so it cannot overlap the representation update (as it
// does without that gradient); what can: the last step's actor update (it
// reads the encoders and the critic, writes only the actor) and this step's
// TD target (target networks only). The worker runs both beside the
// representation update; the representation optimiser waits for them. The
// random draws come in the sequential order (chunks, transitions, noise), so
// the weights are the sequential schedule's bit for bit.
LossInfo Trainer::CriticGradPipelinedStep(bool collect_info, int worker_threads) {
  LossInfo info;
  LossInfo* out = collect_info ? &info : nullptr;
  ++step_;
  if (step_ % options_.agent.target_update_every == 0) {
    Sync();  // runs a deferred actor update first
    UpdateTargets();
  }
  repr_credit_ += options_.representation.updates_per_step;
  std::vector<ChunkBatch> chunks;
  for (double credit = repr_credit_; CreditDue(credit); credit -= 1.0) chunks.push_back(SampleChunks());
  TransitionBatch batch = SampleTransitions();
  torch::Tensor noise = torch::randn({batch.action.size(0), batch.action.size(1)}, gen_, torch::kFloat32);
  std::optional<TransitionBatch> actor_batch = std::move(pending_actor_);
  pending_actor_.reset();
  RunOnWorker(worker_threads, [this, actor_batch = std::move(actor_batch), batch, noise] {
    if (actor_batch) UpdateActor(*actor_batch, EncodeTransitionsForUpdate(*actor_batch), nullptr);
    PrecisionScope precision(bf16(), device_);
    worker_target_ = CriticTarget(batch, noise);
  });
  for (const ChunkBatch& c : chunks) {
    RepresentationBackward(c, out);
    worker_->Wait();  // the actor update read the encoders
    ReduceGrads(*repr_);
    repr_opt_->step();
    repr_credit_ -= 1.0;
  }
  worker_->Wait();
  const torch::Tensor y = std::move(worker_target_);
  worker_target_ = torch::Tensor();
  UpdatePolicyAverage();
  UpdateCriticFromTarget(batch, nullptr, y, out);
  if (collect_info) {
    UpdateActor(batch, EncodeTransitionsForUpdate(batch), out);
  } else {
    pending_actor_ = std::move(batch);
    pending_threads_ = worker_threads;
  }
  return info;
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
        MakeTransitionBatch(sampler.SampleOgbenchTransitions(batch, rng, agent_->SubgoalSteps()), false, &data),
        &info.agent);
    return info;
  }
  RepresentationLoss(MakeChunkBatch(sampler.SampleChunks(batch, rng), false, &data), &info);
  const TransitionBatch tb = MakeTransitionBatch(sampler.SampleTransitions(batch, rng), false, &data);
  CriticLoss(tb, torch::zeros({tb.action.size(0), tb.action.size(1)}), &info);
  ActorLoss(tb, &info);
  return info;
}

Policy Trainer::MakePolicy() {
  Sync();
  if (agent_) return Policy(options_, agent_, device_);
  if (ema_repr_) return Policy(options_, ema_repr_, ema_actor_, ema_critic_, device_);
  return Policy(options_, repr_, actor_, critic_, device_);
}

TrainEnd Trainer::Train(const TrainLoopOptions& loop, const Evaluator& evaluator) {
  const TrainerOptions& t = options_.trainer;
  const int64_t total = t.steps;
  std::unique_ptr<CsvWriter> metrics_csv, eval_csv;
  const LossInfo names = EmptyLossInfo();
  // Data-parallel: rank 0 alone writes, logs and evaluates.
  const bool writer = rank() == 0;
  const bool quiet = loop.quiet || !writer;
  if (!loop.out_dir.empty() && writer) {
    MakeDirs(loop.out_dir);
    // Rows logged after the step this run starts from (a killed run's tail) go.
    TruncateCsvRows(loop.out_dir + "/metrics.csv", step_);
    TruncateCsvRows(loop.out_dir + "/eval.csv", step_);
    std::vector<std::string> cols{"step", "wall_s", "steps_per_s"};
    for (const auto& kv : names.Named()) cols.push_back(kv.first);
    metrics_csv = std::make_unique<CsvWriter>(loop.out_dir + "/metrics.csv", cols);
    eval_csv = std::make_unique<CsvWriter>(loop.out_dir + "/eval.csv",
                                           std::vector<std::string>{"step", "name", "value"});
  }
  ProgressBar bar(step_, total);
  const int64_t first_step = step_;
  const auto start = std::chrono::steady_clock::now();
  auto run_eval = [&]() {
    if (!evaluator || !writer) return;
    Policy policy = MakePolicy();
    const EvalResult res = evaluator(policy, step_);
    std::string line = "eval step " + std::to_string(step_) + ":";
    for (const auto& kv : res) {
      line += " " + kv.first + "=" + std::to_string(kv.second);
      if (eval_csv) eval_csv->WriteRow({std::to_string(step_), kv.first, std::to_string(kv.second)});
    }
    if (!quiet) bar.Message(line);
    NotifyEvalWritten(loop);
  };
  LossInfo last;
  auto out_of_time = [&]() {
    const bool mine = t.time_limit_s > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= t.time_limit_s;
    // Every rank stops at the same step: as soon as one is out of time.
    return (dist_ && t.time_limit_s > 0) ? dist_->Any(mine) : mine;
  };
  auto stop_requested = [&]() {
    if (!loop.stop_requested) return false;
    // Data-parallel ranks poll on the same steps, so that they stop together.
    if (!dist_) return loop.stop_requested->load();
    return step_ % 16 == 0 && dist_->Any(loop.stop_requested->load());
  };
  TrainEnd end = TrainEnd::kSteps;
  while (step_ < total) {
    if (out_of_time()) {
      if (!quiet)
        bar.Message("time limit of " + std::to_string(static_cast<int>(t.time_limit_s)) +
                    " s reached at step " + std::to_string(step_) + ": stopping");
      end = TrainEnd::kTimeLimit;
      break;
    }
    if (stop_requested()) {
      if (!quiet)
        bar.Message("stop requested at step " + std::to_string(step_) +
                    ": writing the checkpoint and the policy (no final evaluation)");
      end = TrainEnd::kStopRequested;
      break;
    }
    // Losses are read back (a device sync) only on logged steps and the
    // representation updates just before them.
    const int64_t next = step_ + 1;
    const bool logged = t.log_every > 0 && (next % t.log_every == 0 || next == total);
    const bool repr_updated = agent_ || ReprUpdateDue(options_.representation.updates_per_step);
    const LossInfo info = Step(logged || (!agent_ && std::isnan(last.repr)));
    if (logged) CheckFiniteLosses(info, repr_updated, step_);
    // Keep the last representation losses on steps without a representation update.
    LossInfo merged = info;
    if (!agent_ && std::isnan(info.repr)) {
      merged.repr = last.repr;
      merged.dyn = last.dyn;
      merged.rew = last.rew;
      merged.inv = last.inv;
      merged.goal_dyn = last.goal_dyn;
      merged.goal_act = last.goal_act;
    }
    last = merged;
    if (t.log_every > 0 && (step_ % t.log_every == 0 || step_ == total)) {
      if (!quiet) {
        if (agent_) {
          // The agent's first four values (its main losses).
          auto named = merged.Named();
          if (named.size() > 4) named.resize(4);
          bar.Update(step_, named);
        } else {
          bar.Update(step_, {{"critic", merged.critic}, {"actor", merged.actor}, {"repr", merged.repr},
                             {"q", merged.q_mean}});
        }
      }
      if (metrics_csv) {
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::vector<double> row{static_cast<double>(step_), wall, bar.steps_per_second()};
        if (quiet) row[2] = wall > 0 ? (step_ - first_step) / wall : 0.0;
        for (const auto& kv : merged.Named()) row.push_back(kv.second);
        metrics_csv->Write(row);
      }
    }
    if (t.eval_every > 0 && step_ % t.eval_every == 0) run_eval();
    if (!loop.out_dir.empty() && t.checkpoint_every > 0 && step_ % t.checkpoint_every == 0) {
      SaveCheckpoint(loop.out_dir + "/checkpoint.ckpt");
    }
    if (writer && !loop.out_dir.empty() && t.export_every > 0 && step_ % t.export_every == 0) {
      ExportPolicy(loop.out_dir + "/policy_step" + std::to_string(step_) + ".pt");
      if (ema_repr_) ExportPolicy(loop.out_dir + "/policy_step" + std::to_string(step_) + "_raw.pt", true);
    }
  }
  if (!quiet) bar.Finish();
  if (evaluator && end != TrainEnd::kStopRequested && (t.eval_every <= 0 || step_ % t.eval_every != 0))
    run_eval();
  if (!loop.out_dir.empty()) {
    SaveCheckpoint(loop.out_dir + "/checkpoint.ckpt");
    if (writer) ExportPolicy(loop.out_dir + "/policy.pt");
    if (writer && ema_repr_) ExportPolicy(loop.out_dir + "/policy_raw.pt", true);
  }
  if (writer) NotifyEvalWritten(loop);
  if (dist_ && step_ > first_step) {
    const Distributed::Stats& st = dist_->stats();
    const double steps = static_cast<double>(step_ - first_step);
    std::fprintf(stderr, "rank %d: all-reduce %.3f ms and %.2f MB per step (%s, %lld collectives)\n", dist_->rank(),
                 1e3 * st.seconds / steps, st.bytes / steps / 1e6, dist_->backend().c_str(),
                 static_cast<long long>(st.allreduces));
  }
  return end;
}

namespace {

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
    for (int r = 1; r < dist_->world_size(); ++r) rank_states.push_back(dist_->Get(key + std::to_string(r)));
  }
  std::vector<torch::nn::Module*> modules;
  for (const auto& [name, m] : CheckpointModules()) modules.push_back(m);
  CheckFiniteWeights(modules, step_, "checkpoint " + path);
  CheckpointHeader header;
  header.options = options_;
  header.step = step_;
  header.repr_credit = repr_credit_;
  std::ostringstream rng;
  rng << rng_;
  header.sampler_rng = rng.str();
  header.rank_states = std::move(rank_states);
  CheckpointFile file;
  file.kind = "trainer";
  file.version = kCheckpointFormatVersion;
  file.header = CheckpointHeaderToYaml(header);
  torch::serialize::OutputArchive archive;
  for (const auto& [name, m] : CheckpointModules()) WriteModule(archive, name, *m);
  if (agent_) {
    torch::serialize::OutputArchive sub;
    agent_opt_->save(sub);
    archive.write("agent_opt", sub);
  } else {
    torch::serialize::OutputArchive sub;
    repr_opt_->save(sub);
    archive.write("repr_opt", sub);
    torch::serialize::OutputArchive critic_sub;
    critic_opt_->save(critic_sub);
    archive.write("critic_opt", critic_sub);
    torch::serialize::OutputArchive actor_sub;
    actor_opt_->save(actor_sub);
    archive.write("actor_opt", actor_sub);
  }
  archive.write("torch_generator", gen_.get_state());
  std::ostringstream payload;
  archive.save_to(payload);
  file.payload = payload.str();
  WriteCheckpointFile(path, file, /*keep_previous=*/true);
}

void Trainer::LoadCheckpoint(const std::string& newest) {
  Sync();
  std::string path;  // newest, or newest.prev when newest fails its CRC
  const CheckpointFile file = ReadCheckpointFileOrPrevious(newest, "trainer", &path);
  const CheckpointHeader header = ParseCheckpointHeader(file.header, path);
  if (NetworkYaml(header.options) != NetworkYaml(options_)) {
    throw CheckpointError(path + ": network or baseline options differ from this trainer's (agent '" +
                          header.options.baseline.agent + "' in the file, '" + options_.baseline.agent +
                          "' here)");
  }
  if ((header.options.trainer.policy_ema > 0) != (options_.trainer.policy_ema > 0)) {
    throw CheckpointError(path + ": trainer.policy_ema is " + std::to_string(header.options.trainer.policy_ema) +
                          " in the file and " + std::to_string(options_.trainer.policy_ema) +
                          " here (a run keeps or lacks the policy's moving average from its start)");
  }
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(file.payload.data(), file.payload.size(), device_);
    for (const auto& [name, m] : CheckpointModules()) ReadModule(archive, name, *m);
    torch::serialize::InputArchive sub;
    if (agent_) {
      archive.read("agent_opt", sub);
      agent_opt_->load(sub);
    } else {
      archive.read("repr_opt", sub);
      repr_opt_->load(sub);
      archive.read("critic_opt", sub);
      critic_opt_->load(sub);
      archive.read("actor_opt", sub);
      actor_opt_->load(sub);
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
      throw CheckpointError(path + ": written by a group of " + std::to_string(header.rank_states.size()) +
                            " rank(s), resumed by " + std::to_string(world) +
                            " (resume with the same world size)");
    }
    RestoreRandomState(header.rank_states[dist_->rank()], path);
  } else if (!header.rank_states.empty()) {
    throw CheckpointError(path + ": written by a group of " + std::to_string(header.rank_states.size()) +
                          " ranks; resume it with --world-size " + std::to_string(header.rank_states.size()));
  }
  step_ = header.step;
  repr_credit_ = header.repr_credit;
}

void Trainer::ExportPolicy(const std::string& path, bool raw) {
  Sync();
  if (agent_) {
    CheckFiniteWeights({agent_.get()}, step_, "policy export " + path);
    WritePolicyExport(path, options_, step_, {{"agent", agent_.get()}});
    return;
  }
  // The moving average when there is one: what MakePolicy() evaluates.
  const bool average = ema_repr_ && !raw;
  torch::nn::Module* repr = average ? ema_repr_.get() : repr_.get();
  torch::nn::Module* actor = average ? ema_actor_.get() : actor_.get();
  torch::nn::Module* critic = average ? ema_critic_.get() : critic_.get();
  CheckFiniteWeights({repr, actor, critic}, step_, "policy export " + path);
  WritePolicyExport(path, options_, step_, {{"repr", repr}, {"actor", actor}, {"critic", critic}});
}

MsprOptions ReadCheckpointOptions(const std::string& newest) {
  std::string path;
  const CheckpointFile file = ReadCheckpointFileOrPrevious(newest, "", &path);
  return ParseCheckpointHeader(file.header, path).options;
}

}  // namespace core
}  // namespace msspr
