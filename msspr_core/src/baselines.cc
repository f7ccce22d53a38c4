#include "msspr_core/baselines.h"

#include <ATen/CPUGeneratorImpl.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "autocast_compat.h"
#include "bf16_weights.h"
#include "layer_norm_bf16.h"
#include "module_io.h"
#include "msspr_core/networks.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;  // log(2 pi)

double Item(const torch::Tensor& t) { return t.detach().to(torch::kCPU).item<double>(); }

// Evaluates networks with their current weights but without gradients to
// them ("frozen", as OGBench's calls without grad params): gradients still
// flow through their inputs.
class Frozen {
 public:
  explicit Frozen(const std::vector<torch::Tensor>& params) : params_(params) {
    for (auto& p : params_) p.set_requires_grad(false);
  }
  ~Frozen() {
    for (auto& p : params_) p.set_requires_grad(true);
  }
  Frozen(const Frozen&) = delete;
  Frozen& operator=(const Frozen&) = delete;

 private:
  std::vector<torch::Tensor> params_;
};

std::vector<torch::Tensor> ParamsOf(const std::vector<torch::nn::Module*>& modules) {
  std::vector<torch::Tensor> out;
  for (torch::nn::Module* m : modules) {
    for (const auto& p : m->parameters()) out.push_back(p);
  }
  return out;
}

torch::Tensor LengthNormalize(const torch::Tensor& x) {
  const double scale = std::sqrt(static_cast<double>(x.size(-1)));
  return x / x.norm(2, -1, /*keepdim=*/true).clamp_min(1e-12) * scale;
}

// linear(x) in fp32 with autocast off: a network's output keeps fp32
// resolution under bf16 (a value near -70 would round to a multiple of 0.5).
torch::Tensor LinearFp32(torch::nn::LinearImpl& linear, const torch::Tensor& x) {
  internal::AutocastOffScope off;
  return torch::linear(x.to(torch::kFloat32), linear.weight, linear.bias);
}

// OGBench's GELU (tanh approximation) of a bfloat16 CPU activation, in fp32
// and rounded to bfloat16 once: 0.5 x (1 + tanh(u / 2)) = x sigmoid(u) with
// u = 2 sqrt(2 / pi) (x + 0.044715 x^3). LibTorch 1.13's tanh-GELU runs a slow
// tanh (the sigmoid form takes about 0.4x its time in fp32, 0.2x in
// bfloat16); the result is its fp32 one within float rounding.
class GeluTanhBf16Fn : public torch::autograd::Function<GeluTanhBf16Fn> {
 public:
  static constexpr double kA = 2.0 * 0.7978845608028654;  // 2 sqrt(2 / pi)
  static constexpr double kC = 0.044715;

  // sigmoid(u(x)) for fp32 x.
  static torch::Tensor Gate(const torch::Tensor& x) {
    return x.square().mul_(kA * kC).add_(kA).mul_(x).sigmoid_();
  }

  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& h) {
    ctx->save_for_backward({h});
    const torch::Tensor x = h.to(torch::kFloat32);
    return Gate(x).mul_(x).to(torch::kBFloat16);
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const torch::Tensor x = ctx->get_saved_variables()[0].to(torch::kFloat32);
    const torch::Tensor s = Gate(x);
    // d/dx x sigmoid(u) = s + x s (1 - s) u', u' = kA (1 + 3 kC x^2).
    torch::Tensor d = x.square().mul_(3.0 * kA * kC).add_(kA).mul_(x).mul_(s).mul_(1.0 - s).add_(s);
    return {d.mul_(grads[0]).to(torch::kBFloat16)};
  }
};

// A new actor of `actor`'s shape holding a copy of its weights, without
// gradient. Torch's generator is restored after its (discarded) initial draws.
GaussianActor CopyOf(GaussianActorImpl& actor) {
  int64_t in = 0, layers = 0;
  for (const auto& m : actor.backbone->net->children()) {
    if (const auto* linear = m->as<torch::nn::Linear>()) {
      if (layers++ == 0) in = linear->options.in_features();
    }
  }
  at::Generator gen = at::detail::getDefaultCPUGenerator();
  const torch::Tensor state = gen.get_state();
  GaussianActor copy(in, actor.head->options.in_features(), layers,
                     actor.head->options.out_features());
  gen.set_state(state);
  copy->to(actor.head->weight.device());
  HardUpdate(*copy, actor);
  SetRequiresGrad(*copy, false);
  return copy;
}

// AWR weights min(exp(alpha * adv), 100).
torch::Tensor AwrWeight(const torch::Tensor& adv, double alpha) {
  return torch::exp(adv * alpha).clamp_max(100.0);
}

// The two heads of an ensemble on one input: [B, 2].
torch::Tensor Twin(OgMlp& a, OgMlp& b, const torch::Tensor& x) {
  return torch::cat({a(x), b(x)}, -1);
}

// OGBench's value loss of a twin V ensemble with target heads (GCIVL, HIQL):
// q = r + gamma m min(Vbar(s')), adv = q - mean(Vbar(s)), and each online
// head regresses on its own target q_i = r + gamma m Vbar_i(s') with the
// expectile weight of adv. next_target, target: [B, 2] without gradient;
// online: [B, 2].
torch::Tensor TwinExpectileValueLoss(const TransitionBatch& batch, const torch::Tensor& next_target,
                                     const torch::Tensor& target, const torch::Tensor& online,
                                     double expectile) {
  const torch::Tensor q = batch.ret + batch.discount * std::get<0>(next_target.min(-1));
  const torch::Tensor w = ExpectileWeight(q - target.mean(-1), expectile);
  const torch::Tensor q1 = batch.ret + batch.discount * next_target.select(-1, 0);
  const torch::Tensor q2 = batch.ret + batch.discount * next_target.select(-1, 1);
  return (w * (q1 - online.select(-1, 0)).pow(2)).mean() +
         (w * (q2 - online.select(-1, 1)).pow(2)).mean();
}

}  // namespace

// --- Building blocks ----------------------------------------------------------

OgMlpImpl::OgMlpImpl(const std::vector<int64_t>& sizes, bool activate_final, bool layer_norm)
    : activate_final_(activate_final) {
  TORCH_CHECK(sizes.size() >= 2, "OgMlp: need at least {in, out}");
  net = torch::nn::Sequential();
  for (size_t i = 0; i + 1 < sizes.size(); ++i) {
    torch::nn::Linear linear(sizes[i], sizes[i + 1]);
    torch::nn::init::xavier_uniform_(linear->weight);
    torch::nn::init::zeros_(linear->bias);
    net->push_back(linear);
    const bool last = i + 2 == sizes.size();
    if (!last || activate_final) {
      net->push_back(torch::nn::GELU(torch::nn::GELUOptions().approximate("tanh")));
      if (layer_norm) {
        net->push_back(torch::nn::LayerNorm(torch::nn::LayerNormOptions({sizes[i + 1]}).eps(1e-6)));
      }
    }
  }
  register_module("net", net);
}

torch::Tensor OgMlpImpl::forward(const torch::Tensor& x) {
  // In fp32 every cast here is a no-op: the plain Sequential's result.
  torch::Tensor h = x;
  for (auto it = net->begin(); it != net->end(); ++it) {
    torch::nn::Module* layer = it->ptr().get();
    if (auto* linear = layer->as<torch::nn::Linear>()) {
      h = !activate_final_ && std::next(it) == net->end() ? LinearFp32(*linear, h)
                                                          : internal::Linear(*linear, h);
      continue;
    }
    if (internal::UseLayerNormBf16(h)) {
      // A bfloat16 activation (bf16 autocast on the CPU): GELU computed in
      // fp32 and rounded once; LayerNorm in one op with fp32 statistics,
      // bfloat16 in and out for the next Linear (src/layer_norm_bf16.h).
      if (layer->as<torch::nn::GELU>()) {
        h = GeluTanhBf16Fn::apply(h);
        continue;
      }
      if (auto* norm = layer->as<torch::nn::LayerNorm>()) {
        h = internal::LayerNormBf16(h, norm->weight, norm->bias, norm->options.eps());
        continue;
      }
    }
    h = it->forward(h.to(torch::kFloat32));  // GELU, LayerNorm in fp32
  }
  return h;
}

GaussianActorImpl::GaussianActorImpl(int64_t in, int64_t hidden, int64_t layers, int64_t out) {
  std::vector<int64_t> sizes{in};
  for (int64_t i = 0; i < layers; ++i) sizes.push_back(hidden);
  backbone =
      register_module("backbone", OgMlp(sizes, /*activate_final=*/true, /*layer_norm=*/false));
  head = register_module("head", torch::nn::Linear(hidden, out));
  // variance_scaling(0.01, fan_avg, uniform): a tenth of Xavier's bound.
  const double bound = 0.1 * std::sqrt(6.0 / static_cast<double>(hidden + out));
  torch::NoGradGuard no_grad;
  head->weight.uniform_(-bound, bound);
  head->bias.zero_();
}

torch::Tensor GaussianActorImpl::Mean(const torch::Tensor& x) {
  return LinearFp32(*head, backbone->forward(x));
}

torch::Tensor GaussianActorImpl::LogProb(const torch::Tensor& x, const torch::Tensor& a) {
  return StdNormalLogProb(a, Mean(x));
}

PairEncoderImpl::PairEncoderImpl(const NetworkOptions& n, int64_t out_dim, int images)
    : downsample(std::max(1, n.image_downsample)), images(images) {
  TORCH_CHECK(images == 1 || images == 2, "PairEncoder: images must be 1 or 2, got ", images);
  // The observation's (and the goal's) images stacked on channels.
  RegisterImageCnn(*this, n, images * int64_t{n.image_channels} * n.frame_stack, out_dim,
                   &light_cnn, &cnn);
}

torch::Tensor PairEncoderImpl::forward(const torch::Tensor& obs, const torch::Tensor& goal) {
  TORCH_CHECK(goal.defined() == (images == 2), "PairEncoder of ", images, " image(s) given ",
              goal.defined() ? "a goal" : "no goal");
  const torch::Tensor x =
      images == 2 ? torch::cat({ImagesToInput(obs, downsample), ImagesToInput(goal, downsample)}, 1)
                  : ImagesToInput(obs, downsample);
  return light_cnn ? light_cnn->forward(x) : cnn->forward(x);
}

torch::Tensor StdNormalLogProb(const torch::Tensor& a, const torch::Tensor& mean) {
  const double d = static_cast<double>(a.size(-1));
  return -0.5 * (a - mean).pow(2).sum(-1) - 0.5 * d * kLog2Pi;
}

torch::Tensor ExpectileWeight(const torch::Tensor& adv, double expectile) {
  return torch::where(adv >= 0, torch::full_like(adv, expectile),
                      torch::full_like(adv, 1.0 - expectile));
}

torch::Tensor IqeDistance(const torch::Tensor& x, const torch::Tensor& y, int64_t k,
                          const torch::Tensor& alpha_raw) {
  TORCH_CHECK(x.sizes() == y.sizes() && x.dim() == 2 && x.size(1) % k == 0,
              "IqeDistance: x and y must be [B, C * k], got ", x.sizes(), " and ", y.sizes());
  const int64_t b = x.size(0), c = x.size(1) / k;
  const torch::Tensor xs = x.reshape({b, c, k}), ys = y.reshape({b, c, k});
  // Sweep the 2k end points in order: coverage falls by one at an interval's
  // start and rises at its end (valid intervals only); the union's length is
  // the sum of the points where coverage leaves 0 minus where it enters it.
  const torch::Tensor valid = (xs < ys).to(x.scalar_type());
  const torch::Tensor points = torch::cat({xs, ys}, -1);
  auto sorted = points.sort(-1);
  const torch::Tensor values = std::get<0>(sorted), order = std::get<1>(sorted);
  const torch::Tensor sign = torch::where(order < k, -1.0, 1.0).to(x.scalar_type());
  const torch::Tensor change = torch::cat({valid, valid}, -1).gather(-1, order) * sign;
  const torch::Tensor inside = (change.cumsum(-1) < 0).to(x.scalar_type()) * -1.0;
  const torch::Tensor edges = torch::cat(
      {inside.narrow(-1, 0, 1), inside.narrow(-1, 1, 2 * k - 1) - inside.narrow(-1, 0, 2 * k - 1)},
      -1);
  const torch::Tensor components = (values * edges).sum(-1);  // [B, C]
  const torch::Tensor a = torch::sigmoid(alpha_raw).reshape({});
  return a * components.mean(-1) + (1.0 - a) * std::get<0>(components.max(-1));
}

// --- OgbenchAgent -------------------------------------------------------------

OgbenchAgent::OgbenchAgent(const MsprOptions& options)
    : GcAgent(options),
      obs_dim_(options.network.obs_dim),
      action_dim_(options.network.action_dim),
      pixels_(options.network.obs_mode == "pixels"),
      pair_dim_(pixels_ ? options.baseline.hidden : 2 * options.network.obs_dim) {
  const std::string& agent = options.baseline.agent;
  if (pixels_ && !AgentTakesImages(agent)) {
    throw OptionsError("baseline agent '" + agent +
                       "': image observations (network.obs_mode 'pixels') are supported by " +
                       ImageBaselinesText() + "; this agent takes states only");
  }
  if (!pixels_ && options.network.obs_mode != "state") {
    throw OptionsError("baseline agent '" + agent + "': unknown network.obs_mode '" +
                       options.network.obs_mode + "'");
  }
  if ((!pixels_ && obs_dim_ <= 0) || action_dim_ <= 0) {
    throw OptionsError("baseline agent '" + agent +
                       "': network.obs_dim and action_dim must be set");
  }
}

OgbenchAgent::~OgbenchAgent() = default;

void OgbenchAgent::PrepareTraining(torch::Device device) {
  device_ = device;
  to(device);
  optimizer_ = std::make_unique<torch::optim::Adam>(
      TrainableParameters(), torch::optim::AdamOptions(options_.baseline.lr));
  if (bf16() && device.is_cpu()) weight_cache_ = std::make_unique<internal::Bf16WeightCache>();
  average_.clear();
  if (options_.trainer.policy_ema > 0) {
    for (auto& [name, online] : ActingNetworks()) {
      average_.push_back({name, online, CopyOf(*online)});
    }
  }
}

LossInfo OgbenchAgent::Step(TrainingContext& context, bool collect_info) {
  LossInfo info;
  NamedValues named;
  const TransitionBatch batch = context.SampleOgbenchTransitions(SubgoalSteps());
  torch::Tensor loss;
  {
    // Backward runs outside autocast, as PyTorch recommends.
    trainer_internal::PrecisionScope precision(bf16(), device_, weight_cache_.get());
    loss = Loss(batch, collect_info ? &named : nullptr);
  }
  optimizer_->zero_grad();
  loss.backward();
  AverageGradients(optimizer_->param_groups().front().params());
  optimizer_->step();
  UpdateTargets();
  UpdatePolicyAverage(context.step());
  if (collect_info) info.agent = std::move(named);
  return info;
}

GaussianActor OgbenchAgent::PolicyAverage(const std::string& name) const {
  for (const Averaged& a : average_) {
    if (a.name == name) return a.average;
  }
  return GaussianActor(nullptr);
}

GaussianActor& OgbenchAgent::ForActing(GaussianActor& online) {
  for (Averaged& a : average_) {
    if (a.online.get() == online.get()) return a.average;
  }
  return online;
}

void OgbenchAgent::UpdatePolicyAverage(int64_t step) {
  if (average_.empty()) return;
  const double t = static_cast<double>(step);
  const double decay = std::min(options_.trainer.policy_ema, t / (t + 1.0));
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> avg, raw;
  for (Averaged& a : average_) {
    for (const auto& p : a.average->parameters()) avg.push_back(p);
    for (const auto& p : a.online->parameters()) raw.push_back(p.detach());
  }
  TORCH_CHECK(avg.size() == raw.size(), "UpdatePolicyAverage: parameter count mismatch");
  torch::_foreach_mul_(avg, decay);
  torch::_foreach_add_(avg, raw, 1.0 - decay);
}

NamedModules OgbenchAgent::CheckpointModules() {
  NamedModules modules{{"agent", this}};
  for (Averaged& a : average_) modules.emplace_back("ema_" + a.name, a.average.get());
  return modules;
}

NamedModules OgbenchAgent::PolicyModules(bool raw) {
  if (raw || average_.empty()) return {{"agent", this}};
  // The agent's own tensors and modules (shared, not copied), the acting
  // networks' averages in their places: saved, it reads as an agent.
  policy_view_ = std::make_shared<torch::nn::Module>(name());
  for (const auto& p : named_parameters(/*recurse=*/false)) {
    policy_view_->register_parameter(p.key(), p.value(), p.value().requires_grad());
  }
  for (const auto& b : named_buffers(/*recurse=*/false)) {
    policy_view_->register_buffer(b.key(), b.value());
  }
  for (const auto& c : named_children()) {
    std::shared_ptr<torch::nn::Module> m = c.value();
    for (Averaged& a : average_) {
      if (a.name == c.key()) m = a.average.ptr();
    }
    policy_view_->register_module(c.key(), m);
  }
  return {{"agent", policy_view_.get()}};
}

LossInfo OgbenchAgent::ValidationLosses(BatchSource& batches) {
  LossInfo info;
  Loss(batches.SampleOgbenchTransitions(SubgoalSteps()), &info.agent);
  return info;
}

void OgbenchAgent::ReadPolicy(torch::serialize::InputArchive& archive, bool trainer_checkpoint) {
  ReadModule(archive, "agent", *this);
  if (trainer_checkpoint && options_.trainer.policy_ema > 0) {
    for (auto& [name, net] : ActingNetworks()) ReadModule(archive, "ema_" + name, *net);
  }
}

std::vector<torch::Tensor> OgbenchAgent::TrainableParameters() {
  std::vector<torch::Tensor> out;
  for (const auto& p : parameters()) {
    if (p.requires_grad()) out.push_back(p);
  }
  return out;
}

void OgbenchAgent::InitTarget(torch::nn::Module& target, const torch::nn::Module& online) {
  HardUpdate(target, online);
  SetRequiresGrad(target, false);
}

void OgbenchAgent::Polyak(torch::nn::Module& target, const torch::nn::Module& online) {
  SoftUpdate(target, online, options_.baseline.tau);
}

torch::Tensor OgbenchAgent::Cat(const torch::Tensor& a, const torch::Tensor& b) {
  return torch::cat({a, b}, -1);
}

torch::Tensor OgbenchAgent::Pair(PairEncoder& encoder, const torch::Tensor& obs,
                                 const torch::Tensor& goal) {
  return encoder ? encoder(obs, goal) : Cat(obs, goal);
}

PairEncoder OgbenchAgent::RegisterPairEncoder(const std::string& name, int images) {
  if (!pixels_) return PairEncoder(nullptr);
  return register_module(name, PairEncoder(options_.network, options_.baseline.hidden, images));
}

torch::Tensor OgbenchAgent::Features(PairEncoder& encoder, const torch::Tensor& obs) {
  return encoder ? encoder(obs) : obs;
}

std::vector<int64_t> OgbenchAgent::Sizes(int64_t in, int64_t out) const {
  std::vector<int64_t> sizes{in};
  for (int i = 0; i < options_.baseline.layers; ++i) sizes.push_back(options_.baseline.hidden);
  sizes.push_back(out);
  return sizes;
}

torch::Tensor OgbenchAgent::DdpgBcLoss(const torch::Tensor& q, const torch::Tensor& log_prob,
                                       NamedValues* info) {
  const torch::Tensor q_loss = -q.mean() / (q.abs().mean().detach() + 1e-6);
  const torch::Tensor bc = -(options_.baseline.alpha * log_prob).mean();
  const torch::Tensor loss = q_loss + bc;
  if (info) {
    info->emplace_back("actor", Item(loss));
    info->emplace_back("q_loss", Item(q_loss));
    info->emplace_back("bc", Item(bc));
  }
  return loss;
}

// --- The one-actor agents -----------------------------------------------------

void GcActorAgent::RegisterActor() {
  const BaselineOptions& b = options_.baseline;
  actor_enc = RegisterPairEncoder("actor_enc");
  actor = register_module("actor", GaussianActor(pair_dim_, b.hidden, b.layers, action_dim_));
}

torch::Tensor GcActorAgent::Act(const torch::Tensor& obs, const torch::Tensor& goal) {
  return ForActing(actor)->Mean(Pair(actor_enc, obs, goal)).clamp(-1.0, 1.0);
}

// --- GCBC ---------------------------------------------------------------------

GcbcAgent::GcbcAgent(const MsprOptions& o) : GcActorAgent(o) { RegisterActor(); }

torch::Tensor GcbcAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  const torch::Tensor mean = actor->Mean(x);
  const torch::Tensor loss = -StdNormalLogProb(batch.action, mean).mean();
  if (info) {
    info->emplace_back("actor", Item(loss));
    info->emplace_back("mse", Item((mean - batch.action).pow(2).sum(-1).mean()));
  }
  return loss;
}

// --- GCIVL --------------------------------------------------------------------

GcivlAgent::GcivlAgent(const MsprOptions& o) : GcActorAgent(o) {
  value_enc = RegisterPairEncoder("value_enc");
  v1 = register_module("v1", OgMlp(Sizes(pair_dim_, 1), false, true));
  v2 = register_module("v2", OgMlp(Sizes(pair_dim_, 1), false, true));
  target_value_enc = RegisterPairEncoder("target_value_enc");
  target_v1 = register_module("target_v1", OgMlp(Sizes(pair_dim_, 1), false, true));
  target_v2 = register_module("target_v2", OgMlp(Sizes(pair_dim_, 1), false, true));
  if (value_enc) InitTarget(*target_value_enc, *value_enc);
  InitTarget(*target_v1, *v1);
  InitTarget(*target_v2, *v2);
  RegisterActor();
}

std::vector<torch::nn::Module*> GcivlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_v1.get(), target_v2.get()};
  if (target_value_enc) t.push_back(target_value_enc.get());
  return t;
}

torch::Tensor GcivlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor s_g = Pair(value_enc, batch.obs, batch.value_goal);
  torch::Tensor next_target, target;
  {
    torch::NoGradGuard no_grad;
    next_target =
        Twin(target_v1, target_v2, Pair(target_value_enc, batch.next_obs, batch.value_goal));
    target = Twin(target_v1, target_v2,
                  value_enc ? Pair(target_value_enc, batch.obs, batch.value_goal) : s_g);
  }
  const torch::Tensor v = Twin(v1, v2, s_g);
  const torch::Tensor value_loss =
      TwinExpectileValueLoss(batch, next_target, target, v, options_.baseline.expectile);

  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  torch::Tensor a_adv;
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor v_x = value_enc ? Pair(value_enc, batch.obs, batch.actor_goal) : x;
    a_adv = Twin(v1, v2, Pair(value_enc, batch.next_obs, batch.actor_goal)).mean(-1) -
            Twin(v1, v2, v_x).mean(-1);
  }
  const torch::Tensor actor_loss =
      -(AwrWeight(a_adv, options_.baseline.alpha) * actor->LogProb(x, batch.action)).mean();
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("v", Item(v.select(-1, 0).mean()));
    info->emplace_back("actor", Item(actor_loss));
    info->emplace_back("adv", Item(a_adv.mean()));
  }
  return value_loss + actor_loss;
}

void GcivlAgent::UpdateTargets() {
  if (value_enc) Polyak(*target_value_enc, *value_enc);
  Polyak(*target_v1, *v1);
  Polyak(*target_v2, *v2);
}

torch::Tensor GcivlAgent::Value(const torch::Tensor& obs, const torch::Tensor&,
                                const torch::Tensor& goal) {
  return Twin(v1, v2, Pair(value_enc, obs, goal));
}

// --- GCIQL --------------------------------------------------------------------

GciqlAgent::GciqlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const int64_t in_q = pair_dim_ + action_dim_;
  value_enc = RegisterPairEncoder("value_enc");
  v = register_module("v", OgMlp(Sizes(pair_dim_, 1), false, true));
  critic_enc = RegisterPairEncoder("critic_enc");
  q1 = register_module("q1", OgMlp(Sizes(in_q, 1), false, true));
  q2 = register_module("q2", OgMlp(Sizes(in_q, 1), false, true));
  target_critic_enc = RegisterPairEncoder("target_critic_enc");
  target_q1 = register_module("target_q1", OgMlp(Sizes(in_q, 1), false, true));
  target_q2 = register_module("target_q2", OgMlp(Sizes(in_q, 1), false, true));
  if (critic_enc) InitTarget(*target_critic_enc, *critic_enc);
  InitTarget(*target_q1, *q1);
  InitTarget(*target_q2, *q2);
  RegisterActor();
}

std::vector<torch::nn::Module*> GciqlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_q1.get(), target_q2.get()};
  if (target_critic_enc) t.push_back(target_critic_enc.get());
  return t;
}

torch::Tensor GciqlAgent::QOf(bool target, const torch::Tensor& obs, const torch::Tensor& goal,
                              const torch::Tensor& action) {
  // States: [s, g, a], one concatenation (as before encoders existed).
  const torch::Tensor x =
      critic_enc ? Cat(Pair(target ? target_critic_enc : critic_enc, obs, goal), action)
                 : torch::cat({obs, goal, action}, -1);
  return target ? Twin(target_q1, target_q2, x) : Twin(q1, q2, x);
}

torch::Tensor GciqlAgent::Q(const torch::Tensor& obs, const torch::Tensor& goal,
                            const torch::Tensor& action) {
  return QOf(false, obs, goal, action);
}

torch::Tensor GciqlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor s_g = Pair(value_enc, batch.obs, batch.value_goal);
  torch::Tensor tq, y;
  {
    torch::NoGradGuard no_grad;
    tq = std::get<0>(QOf(true, batch.obs, batch.value_goal, batch.action).min(-1));
    y = batch.ret +
        batch.discount * v(Pair(value_enc, batch.next_obs, batch.value_goal)).squeeze(-1);
  }
  const torch::Tensor v_s = v(s_g).squeeze(-1);
  const torch::Tensor diff = tq - v_s;
  const torch::Tensor value_loss =
      (ExpectileWeight(diff.detach(), options_.baseline.expectile) * diff.pow(2)).mean();
  const torch::Tensor q = Q(batch.obs, batch.value_goal, batch.action);
  const torch::Tensor critic_loss =
      ((q.select(-1, 0) - y).pow(2) + (q.select(-1, 1) - y).pow(2)).mean();

  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  const torch::Tensor mean = actor->Mean(x);
  torch::Tensor q_pi;
  {
    const Frozen frozen(critic_enc ? ParamsOf({q1.get(), q2.get(), critic_enc.get()})
                                   : ParamsOf({q1.get(), q2.get()}));
    q_pi = std::get<0>(Q(batch.obs, batch.actor_goal, mean.clamp(-1.0, 1.0)).min(-1));
  }
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("critic", Item(critic_loss));
    info->emplace_back("q", Item(q.mean()));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return value_loss + critic_loss + actor_loss;
}

void GciqlAgent::UpdateTargets() {
  if (critic_enc) Polyak(*target_critic_enc, *critic_enc);
  Polyak(*target_q1, *q1);
  Polyak(*target_q2, *q2);
}

torch::Tensor GciqlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                                const torch::Tensor& goal) {
  return Q(obs, goal, action);
}

// --- QRL ----------------------------------------------------------------------

QrlAgent::QrlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const BaselineOptions& b = o.baseline;
  phi = register_module("phi", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  dynamics = register_module("dynamics",
                             OgMlp(Sizes(b.latent_dim + action_dim_, b.latent_dim), false, true));
  alpha_raw = register_parameter("alpha_raw", torch::zeros({1}));
  log_lambda = register_parameter("log_lambda", torch::zeros({1}));
  RegisterActor();
}

torch::Tensor QrlAgent::Distance(const torch::Tensor& zx, const torch::Tensor& zy) {
  return IqeDistance(zx, zy, options_.baseline.iqe_dim, alpha_raw);
}

torch::Tensor QrlAgent::PredictLatent(const torch::Tensor& z, const torch::Tensor& action) {
  return z + dynamics(Cat(z, action));
}

torch::Tensor QrlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const BaselineOptions& b = options_.baseline;
  const torch::Tensor z = phi(batch.obs), z_next = phi(batch.next_obs),
                      z_goal = phi(batch.value_goal);
  const torch::Tensor d_neg = Distance(z, z_goal);
  const torch::Tensor d_pos = Distance(z, z_next);
  const torch::Tensor neg_loss = (100.0 * torch::softplus(5.0 - d_neg / 100.0)).mean();
  const torch::Tensor constraint = torch::relu(d_pos - 1.0).pow(2).mean();
  const torch::Tensor lambda = log_lambda.exp().reshape({});
  const torch::Tensor value_loss = neg_loss + lambda.detach() * constraint;
  const torch::Tensor lambda_loss = lambda * (b.qrl_eps - constraint.detach());
  const torch::Tensor z_hat = PredictLatent(z, batch.action);
  const torch::Tensor dyn_loss = ((Distance(z_next, z_hat) + Distance(z_hat, z_next)) / 2.0).mean();

  const torch::Tensor mean = actor->Mean(Cat(batch.obs, batch.actor_goal));
  torch::Tensor q_pi;
  {
    torch::Tensor zs, zg;
    {
      torch::NoGradGuard no_grad;
      zs = phi(batch.obs);
      zg = phi(batch.actor_goal);
    }
    std::vector<torch::Tensor> frozen_params = ParamsOf({dynamics.get()});
    frozen_params.push_back(alpha_raw);
    const Frozen frozen(frozen_params);
    q_pi = -Distance(PredictLatent(zs, mean.clamp(-1.0, 1.0)), zg);
  }
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("d_neg", Item(d_neg.mean()));
    info->emplace_back("d_pos", Item(d_pos.mean()));
    info->emplace_back("constraint", Item(constraint));
    info->emplace_back("lambda", Item(lambda));
    info->emplace_back("dyn", Item(dyn_loss));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return value_loss + lambda_loss + dyn_loss + actor_loss;
}

torch::Tensor QrlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                              const torch::Tensor& goal) {
  const torch::Tensor q = -Distance(PredictLatent(phi(obs), action), phi(goal)).unsqueeze(-1);
  return torch::cat({q, q}, -1);
}

// --- CRL ----------------------------------------------------------------------

CrlAgent::CrlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const BaselineOptions& b = o.baseline;
  phi1 = register_module("phi1", OgMlp(Sizes(obs_dim_ + action_dim_, b.latent_dim), false, true));
  phi2 = register_module("phi2", OgMlp(Sizes(obs_dim_ + action_dim_, b.latent_dim), false, true));
  psi1 = register_module("psi1", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  psi2 = register_module("psi2", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  RegisterActor();
}

torch::Tensor CrlAgent::PairLogits(int e, const torch::Tensor& obs, const torch::Tensor& action,
                                   const torch::Tensor& goal) {
  OgMlp& phi = e == 0 ? phi1 : phi2;
  OgMlp& psi = e == 0 ? psi1 : psi2;
  const double scale = std::sqrt(static_cast<double>(options_.baseline.latent_dim));
  const torch::Tensor x = phi(Cat(obs, action)), y = psi(goal);
  internal::AutocastOffScope off;  // the logits in fp32 under bf16 too
  return x.matmul(y.t()) / scale;
}

torch::Tensor CrlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const int64_t n = batch.obs.size(0);
  const torch::Tensor eye = torch::eye(n, batch.obs.options());
  torch::Tensor critic_loss = torch::zeros({}, batch.obs.options());
  torch::Tensor logits0;
  for (int e = 0; e < 2; ++e) {
    const torch::Tensor logits = PairLogits(e, batch.obs, batch.action, batch.value_goal);
    critic_loss = critic_loss + torch::binary_cross_entropy_with_logits(logits, eye) / 2.0;
    if (e == 0) logits0 = logits.detach();
  }
  const torch::Tensor mean = actor->Mean(Cat(batch.obs, batch.actor_goal));
  torch::Tensor q_pi;
  {
    const Frozen frozen(ParamsOf({phi1.get(), phi2.get(), psi1.get(), psi2.get()}));
    q_pi = std::get<0>(Value(batch.obs, mean.clamp(-1.0, 1.0), batch.actor_goal).min(-1));
  }
  if (info) {
    const torch::Tensor diag = logits0.diagonal();
    info->emplace_back("critic", Item(critic_loss));
    info->emplace_back("logits_pos", Item(diag.mean()));
    info->emplace_back("logits_neg",
                       n > 1 ? Item((logits0.sum() - diag.sum()) / (n * (n - 1))) : NAN);
    info->emplace_back("accuracy", Item((logits0.argmax(1) ==
                                         torch::arange(n, logits0.options().dtype(torch::kLong)))
                                            .to(torch::kFloat32)
                                            .mean()));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return critic_loss + actor_loss;
}

torch::Tensor CrlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                              const torch::Tensor& goal) {
  const double scale = std::sqrt(static_cast<double>(options_.baseline.latent_dim));
  const torch::Tensor sa = Cat(obs, action);
  const torch::Tensor l1 = (phi1(sa) * psi1(goal)).sum(-1, true) / scale;
  const torch::Tensor l2 = (phi2(sa) * psi2(goal)).sum(-1, true) / scale;
  return torch::cat({l1, l2}, -1);
}

// --- HIQL ---------------------------------------------------------------------

HiqlAgent::HiqlAgent(const MsprOptions& o) : OgbenchAgent(o) {
  const BaselineOptions& b = o.baseline;
  // The observation's features: the state, or (pixels) a CNN's hidden features.
  const int64_t s_dim = pixels_ ? b.hidden : obs_dim_;
  const int64_t in_v = s_dim + b.rep_dim;
  goal_rep_enc = RegisterPairEncoder("goal_rep_enc");
  goal_rep = register_module("goal_rep", OgMlp(Sizes(pair_dim_, b.rep_dim), false, true));
  value_enc = RegisterPairEncoder("value_enc", 1);
  v1 = register_module("v1", OgMlp(Sizes(in_v, 1), false, true));
  v2 = register_module("v2", OgMlp(Sizes(in_v, 1), false, true));
  target_value_enc = RegisterPairEncoder("target_value_enc", 1);
  target_v1 = register_module("target_v1", OgMlp(Sizes(in_v, 1), false, true));
  target_v2 = register_module("target_v2", OgMlp(Sizes(in_v, 1), false, true));
  if (value_enc) InitTarget(*target_value_enc, *value_enc);
  InitTarget(*target_v1, *v1);
  InitTarget(*target_v2, *v2);
  low_actor_enc = RegisterPairEncoder("low_actor_enc", 1);
  low_actor = register_module("low_actor", GaussianActor(in_v, b.hidden, b.layers, action_dim_));
  high_actor_enc = RegisterPairEncoder("high_actor_enc");
  high_actor =
      register_module("high_actor", GaussianActor(pair_dim_, b.hidden, b.layers, b.rep_dim));
}

torch::Tensor HiqlAgent::GoalRep(const torch::Tensor& obs, const torch::Tensor& goal) {
  return LengthNormalize(goal_rep(Pair(goal_rep_enc, obs, goal)));
}

torch::Tensor HiqlAgent::V(const torch::Tensor& obs, const torch::Tensor& goal, bool target) {
  // The target heads (and, pixels, the target's CNN of s) on the online phi.
  const torch::Tensor x =
      Cat(Features(target ? target_value_enc : value_enc, obs), GoalRep(obs, goal));
  return target ? Twin(target_v1, target_v2, x) : Twin(v1, v2, x);
}

torch::Tensor HiqlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const BaselineOptions& b = options_.baseline;
  TORCH_CHECK(batch.low_goal.defined() && batch.high_goal.defined() && batch.high_target.defined(),
              "hiql: the batch has no subgoals (sample it with subgoal_steps > 0)");
  torch::Tensor next_target, target;
  {
    // The target heads on the online goal representation (OGBench shares phi).
    torch::NoGradGuard no_grad;
    next_target = V(batch.next_obs, batch.value_goal, true);
    target = V(batch.obs, batch.value_goal, true);
  }
  const torch::Tensor v = V(batch.obs, batch.value_goal, false);
  const torch::Tensor value_loss =
      TwinExpectileValueLoss(batch, next_target, target, v, b.expectile);

  torch::Tensor low_adv, high_adv, high_target_rep;
  {
    torch::NoGradGuard no_grad;
    low_adv = V(batch.next_obs, batch.low_goal, false).mean(-1) -
              V(batch.obs, batch.low_goal, false).mean(-1);
    high_adv = V(batch.high_target, batch.high_goal, false).mean(-1) -
               V(batch.obs, batch.high_goal, false).mean(-1);
    high_target_rep = GoalRep(batch.obs, batch.high_target);
  }
  torch::Tensor low_rep = GoalRep(batch.obs, batch.low_goal);
  if (!b.low_actor_rep_grad) low_rep = low_rep.detach();
  const torch::Tensor low_loss =
      -(AwrWeight(low_adv, b.low_alpha) *
        low_actor->LogProb(Cat(Features(low_actor_enc, batch.obs), low_rep), batch.action))
           .mean();
  const torch::Tensor high_loss =
      -(AwrWeight(high_adv, b.high_alpha) *
        high_actor->LogProb(Pair(high_actor_enc, batch.obs, batch.high_goal), high_target_rep))
           .mean();
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("v", Item(v.mean()));
    info->emplace_back("low_actor", Item(low_loss));
    info->emplace_back("high_actor", Item(high_loss));
    info->emplace_back("low_adv", Item(low_adv.mean()));
    info->emplace_back("high_adv", Item(high_adv.mean()));
  }
  return value_loss + low_loss + high_loss;
}

void HiqlAgent::UpdateTargets() {
  if (value_enc) Polyak(*target_value_enc, *value_enc);
  Polyak(*target_v1, *v1);
  Polyak(*target_v2, *v2);
}

std::vector<torch::nn::Module*> HiqlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_v1.get(), target_v2.get()};
  if (target_value_enc) t.push_back(target_value_enc.get());
  return t;
}

torch::Tensor HiqlAgent::Act(const torch::Tensor& obs, const torch::Tensor& goal) {
  const torch::Tensor z =
      LengthNormalize(ForActing(high_actor)->Mean(Pair(high_actor_enc, obs, goal)));
  return ForActing(low_actor)->Mean(Cat(Features(low_actor_enc, obs), z)).clamp(-1.0, 1.0);
}

torch::Tensor HiqlAgent::Value(const torch::Tensor& obs, const torch::Tensor&,
                               const torch::Tensor& goal) {
  return V(obs, goal, false);
}

// --- Factory ------------------------------------------------------------------

std::shared_ptr<OgbenchAgent> MakeAgent(const MsprOptions& options) {
  const std::string& name = options.baseline.agent;
  if (name == "gcbc") return std::make_shared<GcbcAgent>(options);
  if (name == "gcivl") return std::make_shared<GcivlAgent>(options);
  if (name == "gciql") return std::make_shared<GciqlAgent>(options);
  if (name == "qrl") return std::make_shared<QrlAgent>(options);
  if (name == "crl") return std::make_shared<CrlAgent>(options);
  if (name == "hiql") return std::make_shared<HiqlAgent>(options);
  throw OptionsError("MakeAgent: '" + name +
                     "' is not a baseline agent (gcbc, gcivl, gciql, qrl, crl, hiql)");
}

}  // namespace core
}  // namespace msspr
