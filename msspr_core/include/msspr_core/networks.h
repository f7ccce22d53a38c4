// Ms.PR networks (the paper's appendix A.2). Names
// given to register_module are checkpoint keys: keep them stable.
// Shapes: B = batch, obs_dim / action_dim from NetworkOptions, images are
// uint8 HWC with C = image_channels * frame_stack.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "msspr_core/options.h"

namespace msspr {
namespace core {

// Linear layers with GELU; Pre-LN (LayerNorm before the Linear) on every
// layer except the first. sizes = {in, hidden..., out}; the last layer has
// GELU when output_gelu, else no activation.
class MlpImpl : public torch::nn::Module {
 public:
  MlpImpl(const std::vector<int64_t>& sizes, bool output_gelu, bool layer_norm = true,
          double eps = 1e-6);
  torch::Tensor forward(const torch::Tensor& x);  // [B, in] float32 -> [B, out] float32
  // Layer kinds in order, e.g. {"Linear", "GELU", "LayerNorm", "Linear"} (for tests).
  std::vector<std::string> LayerKinds() const;

  torch::nn::Sequential net{nullptr};  // "net"
};
TORCH_MODULE(Mlp);

// Impala residual block: conv3x3 -> maxpool(3, 2, 1) -> two residual conv3x3.
class ResidualBlockImpl : public torch::nn::Module {
 public:
  ResidualBlockImpl(int64_t in_channels, int64_t features);
  torch::Tensor forward(
      const torch::Tensor& x);  // [B, in, H, W] -> [B, features, H/2, W/2] float32

  torch::nn::Conv2d cnn1{nullptr}, cnn2{nullptr}, cnn3{nullptr};
  torch::nn::MaxPool2d max_pool{nullptr};
};
TORCH_MODULE(ResidualBlock);

// Impala CNN "small": blocks 16/32/32 channels; 64x64 input gives 8x8x32 =
// 2048 features -> Linear -> GELU.
class ImpalaCnnImpl : public torch::nn::Module {
 public:
  // in_size: the side of the (square) input; 64 gives 2048 features.
  // feature_norm: LayerNorm over the flattened features before fc.
  ImpalaCnnImpl(int64_t in_channels, int64_t out_dim, double eps = 1e-6, int64_t in_size = 64,
                bool feature_norm = false);
  // x: [B, C, S, S] float32 in [0, 1] -> [B, out_dim] float32
  torch::Tensor forward(const torch::Tensor& x);

  ResidualBlock block1{nullptr}, block2{nullptr}, block3{nullptr};
  torch::nn::LayerNorm feature_norm{nullptr};  // null unless feature_norm
  Mlp fc{nullptr};
};
TORCH_MODULE(ImpalaCnn);

// A light CNN for CPU training: three conv3x3 with stride 2 (16/32/32
// channels, ReLU), flattened -> Linear -> GELU. An S x S input gives
// (S/8) x (S/8) x 32 features.
class LightCnnImpl : public torch::nn::Module {
 public:
  LightCnnImpl(int64_t in_channels, int64_t in_size, int64_t out_dim, double eps = 1e-6,
               bool feature_norm = false);
  // x: [B, C, S, S] float32 in [0, 1] -> [B, out_dim] float32
  torch::Tensor forward(const torch::Tensor& x);

  torch::nn::Conv2d conv1{nullptr}, conv2{nullptr}, conv3{nullptr};
  torch::nn::LayerNorm feature_norm{nullptr};  // null unless feature_norm
  Mlp fc{nullptr};
};
TORCH_MODULE(LightCnn);

// E_s: observation -> z_s. MLP (state) or a CNN (pixels: Impala, or the
// light CNN; the image may be average-pooled first), GELU output. Goals use
// the same encoder.
class StateEncoderImpl : public torch::nn::Module {
 public:
  explicit StateEncoderImpl(const NetworkOptions& o);
  // obs: [B, obs_dim] float32 or [B, 64, 64, C] uint8 -> z_s [B, zs_dim] float32
  torch::Tensor forward(const torch::Tensor& obs);

  Mlp mlp{nullptr};             // "mlp" (state mode)
  ImpalaCnn cnn{nullptr};       // "cnn" (pixels mode, network.cnn = impala)
  LightCnn light_cnn{nullptr};  // "light_cnn" (pixels mode, network.cnn = light)
  int64_t downsample = 1;       // network.image_downsample
};
TORCH_MODULE(StateEncoder);

// uint8 [B, H, W, C] images -> float [B, C, H/d, W/d] in [0, 1], each d x d
// block averaged (d = 1: a plain conversion).
torch::Tensor ImagesToInput(const torch::Tensor& images, int64_t d);

// Registers on `owner` the image CNN that o.cnn names: "light_cnn" (LightCnn) when it is
// "light", else "cnn" (OGBench's Impala CNN), over `channels` input channels of images
// o.image_height / o.image_downsample on a side, with out_dim features. Sets the one it
// registers; the other stays empty. Shared by the state encoder and the baselines' pair encoder.
void RegisterImageCnn(torch::nn::Module& owner, const NetworkOptions& o, int64_t channels,
                      int64_t out_dim, LightCnn* light_cnn, ImpalaCnn* cnn);

// psi: [z_s, z_g] -> g_rep, length-normalised to norm sqrt(goal_dim).
class GoalHeadImpl : public torch::nn::Module {
 public:
  explicit GoalHeadImpl(const NetworkOptions& o);
  // zs, zg: [B, zs_dim] float32 -> g_rep [B, goal_dim] float32
  torch::Tensor forward(const torch::Tensor& zs, const torch::Tensor& zg);

  Mlp mlp{nullptr};  // "mlp"
  bool length_normalize;
};
TORCH_MODULE(GoalHead);

// Action encoder: a -> z_a, Linear + GELU.
class ActionEncoderImpl : public torch::nn::Module {
 public:
  explicit ActionEncoderImpl(const NetworkOptions& o);
  torch::Tensor forward(const torch::Tensor& a);  // [B, action_dim] -> [B, za_dim] float32

  torch::nn::Linear linear{nullptr};  // "linear"
};
TORCH_MODULE(ActionEncoder);

// E_sa: [z_s, z_a] -> z_sa (MLP zsa_hidden x2, Pre-LN).
class StateActionEncoderImpl : public torch::nn::Module {
 public:
  explicit StateActionEncoderImpl(const NetworkOptions& o);
  // zs: [B, zs_dim], za: [B, za_dim] -> z_sa [B, zsa_dim] float32
  torch::Tensor forward(const torch::Tensor& zs, const torch::Tensor& za);

  Mlp mlp{nullptr};  // "mlp"
};
TORCH_MODULE(StateActionEncoder);

// The five linear predictors of the multi-scale model.
class PredictorsImpl : public torch::nn::Module {
 public:
  explicit PredictorsImpl(const NetworkOptions& o);
  torch::Tensor Dynamics(const torch::Tensor& zsa);  // [B, zsa_dim] -> z_s' [B, zs_dim]
  // [B, zsa_dim], [B, goal_dim] -> [B, num_bins] logits of the return to g
  torch::Tensor Reward(const torch::Tensor& zsa, const torch::Tensor& grep);
  // [B, zs_dim], [B, zs_dim] -> a [B, action_dim]
  torch::Tensor Inverse(const torch::Tensor& zs, const torch::Tensor& zs_next);
  // [B, zs_dim], [B, goal_dim] -> z_s(t+k) [B, zs_dim]
  torch::Tensor GoalDynamics(const torch::Tensor& zs, const torch::Tensor& grep);
  // [B, zs_dim], [B, goal_dim] -> a_t..a_{t+k-1} [B, k, action_dim]
  torch::Tensor GoalActions(const torch::Tensor& zs, const torch::Tensor& grep);

  torch::nn::Linear dynamics{nullptr}, reward{nullptr}, inverse{nullptr}, goal_dynamics{nullptr},
      goal_action{nullptr};
  int64_t goal_horizon, action_dim;
};
TORCH_MODULE(Predictors);

// Encoders + predictors: everything the representation loss trains.
class RepresentationImpl : public torch::nn::Module {
 public:
  explicit RepresentationImpl(const NetworkOptions& o);
  // z_sa of a state latent and a raw action: [B, zs_dim], [B, action_dim] -> [B, zsa_dim]
  torch::Tensor Zsa(const torch::Tensor& zs, const torch::Tensor& action);

  StateEncoder state_encoder{nullptr};     // "state_encoder"
  GoalHead goal_head{nullptr};             // "goal_head"
  ActionEncoder action_encoder{nullptr};   // "action_encoder"
  StateActionEncoder sa_encoder{nullptr};  // "sa_encoder"
  Predictors predictors{nullptr};          // "predictors"
};
TORCH_MODULE(Representation);

// Which inputs the critic and actor read (NetworkOptions::policy_inputs).
struct PolicyInputs {
  bool latent = true, raw = false;
  explicit PolicyInputs(const std::string& mode)
      : latent(mode != "raw"), raw(mode == "raw" || mode == "both") {}
};

// Twin critic Q_1, Q_2: [z_sa, g_rep] -> 1 each (MLP critic_hidden x3, Pre-LN);
// with network.policy_inputs raw / both, [s, a, g] / [z_sa, g_rep, s, a, g].
class CriticImpl : public torch::nn::Module {
 public:
  explicit CriticImpl(const NetworkOptions& o);
  // [B, zsa_dim], [B, goal_dim] (and the raw state, action and goal [B, obs_dim],
  // [B, action_dim], [B, obs_dim], read only with policy_inputs raw / both)
  // -> [B, 2] float32 (column j = Q_j)
  torch::Tensor forward(const torch::Tensor& zsa, const torch::Tensor& grep,
                        const torch::Tensor& s = {}, const torch::Tensor& a = {},
                        const torch::Tensor& g = {});

  Mlp q1{nullptr}, q2{nullptr};  // "q1", "q2"
  PolicyInputs inputs;
};
TORCH_MODULE(Critic);

// Deterministic actor: [z_s, g_rep] -> tanh action; with network.policy_inputs
// raw / both, [s, g] / [z_s, g_rep, s, g].
class ActorImpl : public torch::nn::Module {
 public:
  explicit ActorImpl(const NetworkOptions& o);
  // [B, zs_dim], [B, goal_dim] (and the raw state and goal [B, obs_dim], read
  // only with policy_inputs raw / both) -> [B, action_dim] float32 in [-1, 1]
  torch::Tensor forward(const torch::Tensor& zs, const torch::Tensor& grep,
                        const torch::Tensor& s = {}, const torch::Tensor& g = {});

  Mlp backbone{nullptr};            // "backbone" (GELU output)
  torch::nn::Linear head{nullptr};  // "head"
  PolicyInputs inputs;
};
TORCH_MODULE(Actor);

// State value V: [z_s, g_rep] -> 1 (MLP critic_hidden x critic_layers, Pre-LN);
// with network.policy_inputs raw / both, [s, g] / [z_s, g_rep, s, g]. Trained
// only with agent.critic_target "expectile" (the in-sample target of IQL).
class ValueImpl : public torch::nn::Module {
 public:
  explicit ValueImpl(const NetworkOptions& o);
  // [B, zs_dim], [B, goal_dim] (and the raw state and goal, read only with
  // policy_inputs raw / both) -> [B] float32
  torch::Tensor forward(const torch::Tensor& zs, const torch::Tensor& grep,
                        const torch::Tensor& s = {}, const torch::Tensor& g = {});

  Mlp v{nullptr};  // "v"
  PolicyInputs inputs;
};
TORCH_MODULE(Value);

// Ms.PR's subgoal actor (agent.subgoal_steps): [z_s, g_rep] -> the state to
// reach on the way to the goal (MLP actor_hidden x actor_layers, Pre-LN,
// linear output); with network.policy_inputs raw / both, [s, g] /
// [z_s, g_rep, s, g].
class SubgoalActorImpl : public torch::nn::Module {
 public:
  explicit SubgoalActorImpl(const NetworkOptions& o);
  // [B, zs_dim], [B, goal_dim] (and the raw state and goal, read only with
  // policy_inputs raw / both) -> [B, obs_dim] float32
  torch::Tensor forward(const torch::Tensor& zs, const torch::Tensor& grep,
                        const torch::Tensor& s = {}, const torch::Tensor& g = {});

  Mlp net{nullptr};  // "net"
  PolicyInputs inputs;
};
TORCH_MODULE(SubgoalActor);

// Returns the K bin centres of the two-hot return head:
// linspace(-1/(1-gamma), 0, K) [K] float32.
torch::Tensor ReturnBins(int64_t num_bins, double gamma);
// Two-hot encoding of values [B] over bins [K] -> [B, K] (values clamped to
// the bins' range; the two neighbouring bins share the mass linearly).
torch::Tensor TwoHotEncode(const torch::Tensor& values, const torch::Tensor& bins);
// Same with the bins' range given (no device-to-host read of the bins).
torch::Tensor TwoHotEncode(const torch::Tensor& values, const torch::Tensor& bins, double lo,
                           double hi);
// Expected value of softmax(logits) over bins: [B, K] -> [B].
torch::Tensor TwoHotDecode(const torch::Tensor& logits, const torch::Tensor& bins);

// Copies parameters and buffers of `source` into `target` (same structure).
void HardUpdate(torch::nn::Module& target, const torch::nn::Module& source);
// The Polyak average of target networks: target <- tau source + (1 - tau)
// target, parameter by parameter (same structure; buffers are left alone).
void SoftUpdate(torch::nn::Module& target, const torch::nn::Module& source, double tau);
// Sets requires_grad of all parameters.
void SetRequiresGrad(torch::nn::Module& module, bool requires_grad);

}  // namespace core
}  // namespace msspr
