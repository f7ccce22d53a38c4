#include "msspr_core/baselines.h"

#include <ATen/CPUGeneratorImpl.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "autocast_compat.h"
#include "baselines_internal.h"
#include "bf16_weights.h"
#include "gelu_layer_norm.h"
#include "module_io.h"
#include "msspr_core/networks.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;  // log(2 pi)

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

}  // namespace

namespace baselines_internal {

double Item(const torch::Tensor& t) { return t.detach().to(torch::kCPU).item<double>(); }

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

}  // namespace baselines_internal

using namespace baselines_internal;

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
      h = !activate_final_ && std::next(it) == net->end() ? internal::LinearFp32(*linear, h)
                                                          : internal::Linear(*linear, h);
      continue;
    }
    if (internal::UseLayerNormBf16(h)) {
      // A bfloat16 activation (bf16 autocast on the CPU): GELU computed in
      // fp32 and rounded once; LayerNorm in one op with fp32 statistics,
      // bfloat16 in and out for the next Linear (src/gelu_layer_norm.h).
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
  return internal::LinearFp32(*head, backbone->forward(x));
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
