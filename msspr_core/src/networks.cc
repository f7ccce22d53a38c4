#include "msspr_core/networks.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <iterator>

#include "autocast_compat.h"
#include "bf16_weights.h"
#include "gelu_layer_norm.h"

namespace msspr {
namespace core {
namespace nn = torch::nn;

MlpImpl::MlpImpl(const std::vector<int64_t>& sizes, bool output_gelu, bool layer_norm, double eps) {
  TORCH_CHECK(sizes.size() >= 2, "Mlp needs at least input and output sizes");
  net = nn::Sequential();
  for (size_t j = 0; j + 1 < sizes.size(); ++j) {
    if (layer_norm && j > 0) {
      net->push_back(nn::LayerNorm(nn::LayerNormOptions({sizes[j]}).eps(eps)));
    }
    net->push_back(nn::Linear(sizes[j], sizes[j + 1]));
    const bool last = j + 2 == sizes.size();
    if (!last || output_gelu) net->push_back(nn::GELU());
  }
  register_module("net", net);
}

namespace {
// The fp32 fused ops serve training (an activation that autograd tracks). Without
// a graph (Act, evaluation, target networks) LibTorch's ops run, so that a
// trained policy acts as it did before they existed, bit for bit, and every
// figure measured from a shipped checkpoint reproduces.
bool UseFusedFp32ForTraining(const torch::Tensor& h) {
  return h.requires_grad() && internal::UseFusedFp32(h);
}

// GELU (exact, erf): one op on a bfloat16 CPU tensor or a tracked float32 one,
// LibTorch's otherwise.
torch::Tensor Gelu(const torch::Tensor& h) {
  if (internal::UseLayerNormBf16(h)) return internal::GeluBf16(h);
  if (UseFusedFp32ForTraining(h)) return internal::GeluFp32(h);
  return torch::gelu(h);
}

// MlpImpl::forward; fp32_output: the last Linear as LinearFp32.
torch::Tensor MlpForward(MlpImpl& mlp, const torch::Tensor& x, bool fp32_output) {
  // Under bf16 autocast (trainer.precision) a Linear returns bfloat16, and
  // LayerNorm (fp32 weights) is computed in fp32. On the CPU one op does it
  // and returns bfloat16 for the next Linear (internal::LayerNormBf16), with
  // the GELU before it (internal::GeluLayerNormBf16); elsewhere its input is
  // cast up here. In fp32 on the CPU, in training, the GELU and the LayerNorm
  // after it are one op too (internal::GeluLayerNormFp32), and the casts are
  // no-ops.
  torch::Tensor h = x;
  nn::Sequential& net = mlp.net;
  for (auto it = net->begin(); it != net->end(); ++it) {
    torch::nn::Module* layer = it->ptr().get();
    if (auto* linear = layer->as<nn::Linear>()) {
      h = fp32_output && std::next(it) == net->end() ? internal::LinearFp32(*linear, h)
                                                     : internal::Linear(*linear, h);
      continue;
    }
    if (layer->as<nn::GELU>()) {
      auto next = std::next(it);
      nn::LayerNormImpl* norm = next != net->end() ? next->ptr()->as<nn::LayerNorm>() : nullptr;
      if (norm && internal::UseLayerNormBf16(h)) {
        h = internal::GeluLayerNormBf16(h, norm->weight, norm->bias, norm->options.eps());
        it = next;
      } else if (norm && UseFusedFp32ForTraining(h)) {
        h = internal::GeluLayerNormFp32(h, norm->weight, norm->bias, norm->options.eps());
        it = next;
      } else {
        h = Gelu(h);
      }
      continue;
    }
    if (auto* norm = layer->as<nn::LayerNorm>()) {
      if (internal::UseLayerNormBf16(h)) {
        h = internal::LayerNormBf16(h, norm->weight, norm->bias, norm->options.eps());
        continue;
      }
      h = h.to(torch::kFloat32);
    }
    h = it->forward(h);
  }
  return h;
}
}  // namespace

torch::Tensor MlpImpl::forward(const torch::Tensor& x) { return MlpForward(*this, x, false); }

std::vector<std::string> MlpImpl::LayerKinds() const {
  std::vector<std::string> kinds;
  for (const auto& m : net->children()) {
    if (m->as<nn::Linear>())
      kinds.push_back("Linear");
    else if (m->as<nn::LayerNorm>())
      kinds.push_back("LayerNorm");
    else if (m->as<nn::GELU>())
      kinds.push_back("GELU");
    else
      kinds.push_back(m->name());
  }
  return kinds;
}

ResidualBlockImpl::ResidualBlockImpl(int64_t in_channels, int64_t features) {
  cnn1 =
      register_module("cnn1", nn::Conv2d(nn::Conv2dOptions(in_channels, features, 3).padding(1)));
  cnn2 = register_module("cnn2", nn::Conv2d(nn::Conv2dOptions(features, features, 3).padding(1)));
  cnn3 = register_module("cnn3", nn::Conv2d(nn::Conv2dOptions(features, features, 3).padding(1)));
  max_pool =
      register_module("max_pool", nn::MaxPool2d(nn::MaxPool2dOptions(3).stride(2).padding(1)));
}

torch::Tensor ResidualBlockImpl::forward(const torch::Tensor& x) {
  torch::Tensor x1 = max_pool->forward(cnn1->forward(x));
  torch::Tensor x2 = cnn2->forward(torch::relu(x1));
  x2 = cnn3->forward(torch::relu(x2));
  return x1 + x2;
}

namespace {
// The flattened CNN features, layer-normalised (in fp32) when `norm` is set.
torch::Tensor Features(const torch::Tensor& h, torch::nn::LayerNorm& norm) {
  const torch::Tensor flat = h.flatten(1);
  return norm ? norm->forward(flat.to(torch::kFloat32)) : flat;
}
}  // namespace

ImpalaCnnImpl::ImpalaCnnImpl(int64_t in_channels, int64_t out_dim, double eps, int64_t in_size,
                             bool feature_norm_on) {
  block1 = register_module("block1", ResidualBlock(in_channels, 16));
  block2 = register_module("block2", ResidualBlock(16, 32));
  block3 = register_module("block3", ResidualBlock(32, 32));
  const int64_t side = (in_size + 7) / 8;  // three maxpools (3, stride 2, pad 1)
  if (feature_norm_on) {
    feature_norm = register_module(
        "feature_norm",
        torch::nn::LayerNorm(torch::nn::LayerNormOptions({32 * side * side}).eps(eps)));
  }
  fc = register_module("fc", Mlp(std::vector<int64_t>{32 * side * side, out_dim}, true, true, eps));
}

torch::Tensor ImpalaCnnImpl::forward(const torch::Tensor& x) {
  return fc->forward(Features(block3->forward(block2->forward(block1->forward(x))), feature_norm));
}

LightCnnImpl::LightCnnImpl(int64_t in_channels, int64_t in_size, int64_t out_dim, double eps,
                           bool feature_norm_on) {
  auto conv = [](int64_t in, int64_t out) {
    return nn::Conv2d(nn::Conv2dOptions(in, out, 3).stride(2).padding(1));
  };
  conv1 = register_module("conv1", conv(in_channels, 16));
  conv2 = register_module("conv2", conv(16, 32));
  conv3 = register_module("conv3", conv(32, 32));
  const int64_t side = (in_size + 7) / 8;
  if (feature_norm_on) {
    feature_norm = register_module(
        "feature_norm",
        torch::nn::LayerNorm(torch::nn::LayerNormOptions({32 * side * side}).eps(eps)));
  }
  fc = register_module("fc", Mlp(std::vector<int64_t>{32 * side * side, out_dim}, true, true, eps));
}

torch::Tensor LightCnnImpl::forward(const torch::Tensor& x) {
  torch::Tensor h = torch::relu(conv1->forward(x));
  h = torch::relu(conv2->forward(h));
  h = torch::relu(conv3->forward(h));
  return fc->forward(Features(h, feature_norm));
}

namespace {
std::vector<int64_t> Sizes(int64_t in, int64_t hidden, int64_t layers, int64_t out) {
  std::vector<int64_t> s{in};
  for (int64_t i = 0; i < layers; ++i) s.push_back(hidden);
  s.push_back(out);
  return s;
}
}  // namespace

StateEncoderImpl::StateEncoderImpl(const NetworkOptions& o) : downsample(o.image_downsample) {
  if (o.obs_mode == "pixels") {
    RegisterImageCnn(*this, o, int64_t{o.image_channels} * o.frame_stack, o.zs_dim, &light_cnn,
                     &cnn);
  } else {
    mlp = register_module("mlp", Mlp(Sizes(o.obs_dim, o.encoder_hidden, o.encoder_layers, o.zs_dim),
                                     true, true, o.layer_norm_eps));
  }
}

void RegisterImageCnn(torch::nn::Module& owner, const NetworkOptions& o, int64_t channels,
                      int64_t out_dim, LightCnn* light_cnn, ImpalaCnn* cnn) {
  const int64_t side = o.image_height / std::max(1, o.image_downsample);
  if (o.cnn == "light") {
    *light_cnn = owner.register_module(
        "light_cnn", LightCnn(channels, side, out_dim, o.layer_norm_eps, o.cnn_feature_norm));
  } else {
    *cnn = owner.register_module(
        "cnn", ImpalaCnn(channels, out_dim, o.layer_norm_eps, side, o.cnn_feature_norm));
  }
}

torch::Tensor ImagesToInput(const torch::Tensor& images, int64_t d) {
  TORCH_CHECK(images.dim() == 4 && images.scalar_type() == torch::kUInt8,
              "StateEncoder expects [B, H, W, C] uint8 images, got ", images.sizes(), " ",
              images.scalar_type());
  const int64_t n = images.size(0), h = images.size(1), w = images.size(2), c = images.size(3);
  TORCH_CHECK(d >= 1 && h % d == 0 && w % d == 0, "image size ", h, "x", w,
              " is not a multiple of the downsampling factor ", d);
  if (!images.device().is_cpu()) {
    torch::Tensor x = images.permute({0, 3, 1, 2}).to(torch::kFloat32);
    if (d > 1) x = torch::avg_pool2d(x, {d, d});
    return x.div(255.0);
  }
  // One pass on the CPU into a channels-last float tensor (oneDNN's fast
  // layout for these convolutions): LibTorch's strided permute-and-convert
  // plus avg_pool2d took over half of a light-CNN training step.
  const torch::Tensor src = images.contiguous();
  const int64_t oh = h / d, ow = w / d;
  torch::Tensor out = torch::empty({n, oh, ow, c}, torch::kFloat32);
  const uint8_t* in = src.data_ptr<uint8_t>();
  float* o = out.data_ptr<float>();
  const float scale = 1.0f / (255.0f * static_cast<float>(d * d));
  at::parallel_for(0, n, 1, [&](int64_t begin, int64_t end) {
    for (int64_t b = begin; b < end; ++b) {
      const uint8_t* img = in + b * h * w * c;
      float* dst = o + b * oh * ow * c;
      if (d == 1) {
        for (int64_t i = 0; i < h * w * c; ++i) dst[i] = img[i] * scale;
        continue;
      }
      for (int64_t y = 0; y < oh; ++y) {
        float* row = dst + y * ow * c;
        std::fill(row, row + ow * c, 0.0f);
        for (int64_t dy = 0; dy < d; ++dy) {
          const uint8_t* line = img + (y * d + dy) * w * c;
          for (int64_t x = 0; x < ow; ++x) {
            for (int64_t dx = 0; dx < d; ++dx) {
              const uint8_t* px = line + (x * d + dx) * c;
              for (int64_t ch = 0; ch < c; ++ch) row[x * c + ch] += px[ch];
            }
          }
        }
        for (int64_t i = 0; i < ow * c; ++i) row[i] *= scale;
      }
    }
  });
  return out.permute({0, 3, 1, 2});  // [B, C, H/d, W/d], channels-last strides
}

torch::Tensor StateEncoderImpl::forward(const torch::Tensor& obs) {
  if (mlp) return mlp->forward(obs);
  // uint8 HWC -> float NCHW in [0, 1], average-pooled by `downsample`.
  const torch::Tensor x = ImagesToInput(obs, downsample);
  return light_cnn ? light_cnn->forward(x) : cnn->forward(x);
}

GoalHeadImpl::GoalHeadImpl(const NetworkOptions& o) : length_normalize(o.length_normalize) {
  mlp = register_module(
      "mlp", Mlp(Sizes(2 * o.zs_dim, o.goal_hidden, 2, o.goal_dim), false, true, o.layer_norm_eps));
}

torch::Tensor GoalHeadImpl::forward(const torch::Tensor& zs, const torch::Tensor& zg) {
  torch::Tensor x = mlp->forward(torch::cat({zs, zg}, -1)).to(torch::kFloat32);
  if (!length_normalize) return x;
  const double scale = std::sqrt(static_cast<double>(x.size(-1)));
  return x / x.norm(2, -1, true).clamp_min(1e-6) * scale;
}

ActionEncoderImpl::ActionEncoderImpl(const NetworkOptions& o) {
  linear = register_module("linear", nn::Linear(o.action_dim, o.za_dim));
}

torch::Tensor ActionEncoderImpl::forward(const torch::Tensor& a) {
  return Gelu(internal::Linear(*linear, a));
}

StateActionEncoderImpl::StateActionEncoderImpl(const NetworkOptions& o) {
  mlp = register_module("mlp", Mlp(Sizes(o.zs_dim + o.za_dim, o.zsa_hidden, 2, o.zsa_dim), false,
                                   true, o.layer_norm_eps));
}

torch::Tensor StateActionEncoderImpl::forward(const torch::Tensor& zs, const torch::Tensor& za) {
  return mlp->forward(torch::cat({zs, za}, -1));
}

PredictorsImpl::PredictorsImpl(const NetworkOptions& o)
    : goal_horizon(o.goal_horizon), action_dim(o.action_dim) {
  dynamics = register_module("dynamics", nn::Linear(o.zsa_dim, o.zs_dim));
  reward = register_module("reward", nn::Linear(o.zsa_dim + o.goal_dim, o.num_bins));
  inverse = register_module("inverse", nn::Linear(2 * o.zs_dim, o.action_dim));
  goal_dynamics = register_module("goal_dynamics", nn::Linear(o.zs_dim + o.goal_dim, o.zs_dim));
  goal_action = register_module(
      "goal_action", nn::Linear(o.zs_dim + o.goal_dim, int64_t{o.goal_horizon} * o.action_dim));
}

torch::Tensor PredictorsImpl::Dynamics(const torch::Tensor& zsa) {
  return internal::Linear(*dynamics, zsa);
}

torch::Tensor PredictorsImpl::Reward(const torch::Tensor& zsa, const torch::Tensor& grep) {
  return internal::Linear(*reward, torch::cat({zsa, grep}, -1));
}

torch::Tensor PredictorsImpl::Inverse(const torch::Tensor& zs, const torch::Tensor& zs_next) {
  return internal::Linear(*inverse, torch::cat({zs, zs_next}, -1));
}

torch::Tensor PredictorsImpl::GoalDynamics(const torch::Tensor& zs, const torch::Tensor& grep) {
  return internal::Linear(*goal_dynamics, torch::cat({zs, grep}, -1));
}

torch::Tensor PredictorsImpl::GoalActions(const torch::Tensor& zs, const torch::Tensor& grep) {
  return internal::Linear(*goal_action, torch::cat({zs, grep}, -1))
      .view({-1, goal_horizon, action_dim});
}

RepresentationImpl::RepresentationImpl(const NetworkOptions& o) {
  state_encoder = register_module("state_encoder", StateEncoder(o));
  goal_head = register_module("goal_head", GoalHead(o));
  action_encoder = register_module("action_encoder", ActionEncoder(o));
  sa_encoder = register_module("sa_encoder", StateActionEncoder(o));
  predictors = register_module("predictors", Predictors(o));
}

torch::Tensor RepresentationImpl::Zsa(const torch::Tensor& zs, const torch::Tensor& action) {
  return sa_encoder->forward(zs, action_encoder->forward(action));
}

namespace {
// The inputs a critic or actor reads, concatenated: the latent ones, the raw ones, or both.
torch::Tensor PolicyInput(const PolicyInputs& in, std::vector<torch::Tensor> latent,
                          const std::vector<torch::Tensor>& raw) {
  if (!in.latent) latent.clear();
  if (in.raw) {
    for (const auto& t : raw)
      TORCH_CHECK(t.defined(),
                  "network.policy_inputs reads the raw state, action and goal: not given");
    latent.insert(latent.end(), raw.begin(), raw.end());
  }
  return torch::cat(latent, -1);
}

// The width of what an actor or a value network reads: [z_s, g_rep] and/or [s, g].
int64_t StateGoalInputSize(const PolicyInputs& in, const NetworkOptions& o) {
  return (in.latent ? o.zs_dim + o.goal_dim : 0) + (in.raw ? 2 * o.obs_dim : 0);
}
}  // namespace

CriticImpl::CriticImpl(const NetworkOptions& o) : inputs(o.policy_inputs) {
  const int64_t in = (inputs.latent ? o.zsa_dim + o.goal_dim : 0) +
                     (inputs.raw ? 2 * o.obs_dim + o.action_dim : 0);
  const auto sizes = Sizes(in, o.critic_hidden, o.critic_layers, 1);
  q1 = register_module("q1", Mlp(sizes, false, true, o.layer_norm_eps));
  q2 = register_module("q2", Mlp(sizes, false, true, o.layer_norm_eps));
}

torch::Tensor CriticImpl::forward(const torch::Tensor& zsa, const torch::Tensor& grep,
                                  const torch::Tensor& s, const torch::Tensor& a,
                                  const torch::Tensor& g) {
  const torch::Tensor x = PolicyInput(inputs, {zsa, grep}, {s, a, g});
  return torch::cat({MlpForward(*q1, x, true), MlpForward(*q2, x, true)}, -1);
}

ActorImpl::ActorImpl(const NetworkOptions& o) : inputs(o.policy_inputs) {
  std::vector<int64_t> sizes{StateGoalInputSize(inputs, o)};
  for (int i = 0; i < o.actor_layers; ++i) sizes.push_back(o.actor_hidden);
  backbone = register_module("backbone", Mlp(sizes, true, true, o.layer_norm_eps));
  head = register_module("head", nn::Linear(o.actor_hidden, o.action_dim));
}

torch::Tensor ActorImpl::forward(const torch::Tensor& zs, const torch::Tensor& grep,
                                 const torch::Tensor& s, const torch::Tensor& g) {
  return torch::tanh(
      internal::Linear(*head, backbone->forward(PolicyInput(inputs, {zs, grep}, {s, g}))));
}

ValueImpl::ValueImpl(const NetworkOptions& o) : inputs(o.policy_inputs) {
  v = register_module(
      "v", Mlp(Sizes(StateGoalInputSize(inputs, o), o.critic_hidden, o.critic_layers, 1), false,
               true, o.layer_norm_eps));
}

torch::Tensor ValueImpl::forward(const torch::Tensor& zs, const torch::Tensor& grep,
                                 const torch::Tensor& s, const torch::Tensor& g) {
  return MlpForward(*v, PolicyInput(inputs, {zs, grep}, {s, g}), true).squeeze(-1);
}

SubgoalActorImpl::SubgoalActorImpl(const NetworkOptions& o) : inputs(o.policy_inputs) {
  net = register_module(
      "net", Mlp(Sizes(StateGoalInputSize(inputs, o), o.actor_hidden, o.actor_layers, o.obs_dim),
                 false, true, o.layer_norm_eps));
}

torch::Tensor SubgoalActorImpl::forward(const torch::Tensor& zs, const torch::Tensor& grep,
                                        const torch::Tensor& s, const torch::Tensor& g) {
  return MlpForward(*net, PolicyInput(inputs, {zs, grep}, {s, g}), true);
}

torch::Tensor ReturnBins(int64_t num_bins, double gamma) {
  return torch::linspace(-1.0 / (1.0 - gamma), 0.0, num_bins, torch::kFloat32);
}

torch::Tensor TwoHotEncode(const torch::Tensor& values, const torch::Tensor& bins) {
  return TwoHotEncode(values, bins, bins[0].item<double>(), bins[bins.size(0) - 1].item<double>());
}

torch::Tensor TwoHotEncode(const torch::Tensor& values, const torch::Tensor& bins, double lo,
                           double hi) {
  const int64_t k = bins.size(0);
  const torch::Tensor v = values.clamp(lo, hi);
  const torch::Tensor pos = (v - lo) / (hi - lo) * (k - 1);  // fractional bin index
  const torch::Tensor below = pos.floor().clamp(0, k - 2).to(torch::kLong);
  const torch::Tensor w_above = (pos - below.to(pos.dtype())).unsqueeze(-1);
  torch::Tensor out = torch::zeros({values.size(0), k}, values.options());
  out.scatter_(1, below.unsqueeze(-1), 1.0 - w_above);
  out.scatter_add_(1, below.unsqueeze(-1) + 1, w_above);
  return out;
}

torch::Tensor TwoHotDecode(const torch::Tensor& logits, const torch::Tensor& bins) {
  return (torch::softmax(logits, -1) * bins.to(logits.device())).sum(-1);
}

void HardUpdate(torch::nn::Module& target, const torch::nn::Module& source) {
  torch::NoGradGuard no_grad;
  const auto src_p = source.parameters();
  auto dst_p = target.parameters();
  TORCH_CHECK(src_p.size() == dst_p.size(), "HardUpdate: parameter count mismatch");
  for (size_t i = 0; i < src_p.size(); ++i) dst_p[i].copy_(src_p[i]);
  const auto src_b = source.buffers();
  auto dst_b = target.buffers();
  TORCH_CHECK(src_b.size() == dst_b.size(), "HardUpdate: buffer count mismatch");
  for (size_t i = 0; i < src_b.size(); ++i) dst_b[i].copy_(src_b[i]);
}

void SoftUpdate(torch::nn::Module& target, const torch::nn::Module& source, double tau) {
  torch::NoGradGuard no_grad;
  auto dst = target.parameters();
  const auto src = source.parameters();
  TORCH_CHECK(src.size() == dst.size(), "SoftUpdate: parameter count mismatch");
  for (size_t i = 0; i < dst.size(); ++i) dst[i].mul_(1.0 - tau).add_(src[i], tau);
}

void SetRequiresGrad(torch::nn::Module& module, bool requires_grad) {
  for (auto& p : module.parameters()) p.set_requires_grad(requires_grad);
}

}  // namespace core
}  // namespace msspr
