// OGBench's goal-conditioned baseline agents in LibTorch: GCBC, GCIVL,
// GCIQL, QRL, CRL and HIQL (the facts of
// github.com/seohongpark/ogbench impls/agents/*.py). They share Ms.PR's
// dataset, relabelling (BatchSampler::SampleOgbenchTransitions), trainer
// loop, checkpoints, export and Policy through the GcAgent interface
// (gc_agent.h); OgbenchAgent implements it once for all six, and each agent
// here adds only its networks, its losses and its acting rule.
//
// Observations: states for all six; images (network.obs_mode "pixels") for
// GCBC, GCIVL, GCIQL and HIQL, as OGBench's visual agents read them: each
// network that takes an (observation, goal) pair has its own encoder of the
// two images stacked on channels (OGBench's GCEncoder(concat_encoder=...)), a
// CNN (network.cnn: the Impala CNN or the light CNN, network.image_downsample
// and network.cnn_feature_norm as Ms.PR's) whose features (baseline.hidden
// of them) replace [s, g]; HIQL's value and low actor read s through a CNN of
// their own (GCEncoder(state_encoder=...)). Target networks copy their encoder.
//
// Conventions, as OGBench:
// - MLPs: Linear -> GELU (tanh approximation) -> LayerNorm (eps 1e-6) per
//   hidden layer; Xavier-uniform weights, zero biases.
// - Actors: a Gaussian with a constant std of 1 whose mean is an MLP
//   (no LayerNorm) with a small final layer; log pi(a) = -0.5 ||a - mu||^2
//   - 0.5 D log(2 pi); acting uses the mean, clipped to [-1, 1].
// - "Frozen" networks are evaluated with their current weights and pass no
//   gradient to them; targets are Polyak averages (baseline.tau).
// - One scalar loss (the sum of the agent's losses) and one Adam step (no
//   weight decay, all parameters but the targets') per training step.
//
// trainer.precision "bf16": the step's loss runs under bf16 autocast (on the
// CPU with Ms.PR's cache of bfloat16 weight copies); weights, optimiser state
// and targets stay fp32. The hidden layers' matrix products are bfloat16; GELU
// and LayerNorm compute in fp32 (on the CPU with bfloat16 activations in and
// out); the last Linear of every network (values, Q, latents, the actors'
// means) runs in fp32: a value near -70 would round to a multiple of 0.5 in
// bfloat16. CRL's pair logits are an fp32 product too.
// trainer.policy_ema: the trainer keeps a moving average of the acting
// networks (the actor; HIQL's low and high actors), which the exports and
// the in-training policy act with.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "msspr_core/batches.h"
#include "msspr_core/gc_agent.h"
#include "msspr_core/networks.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

namespace internal {
class Bf16WeightCache;
}

// OGBench's MLP. sizes = {in, hidden..., out}; the last layer has GELU (and
// LayerNorm when layer_norm) only when activate_final. Under bf16 autocast
// the hidden Linears return bfloat16, GELU and LayerNorm compute in fp32
// (on the CPU: bfloat16 in and out), and without activate_final the last
// Linear (the output: a value, a latent) runs in fp32 and returns fp32.
class OgMlpImpl : public torch::nn::Module {
 public:
  OgMlpImpl(const std::vector<int64_t>& sizes, bool activate_final, bool layer_norm);
  torch::Tensor forward(const torch::Tensor& x);  // [B, in] -> [B, out]

  torch::nn::Sequential net{nullptr};  // "net"

 private:
  bool activate_final_;
};
TORCH_MODULE(OgMlp);

// OGBench's GCActor with const_std: mean = head(MLP(x)), std 1. The head
// runs in fp32 under bf16 autocast (the mean is fp32).
class GaussianActorImpl : public torch::nn::Module {
 public:
  GaussianActorImpl(int64_t in, int64_t hidden, int64_t layers, int64_t out);
  torch::Tensor Mean(const torch::Tensor& x);  // [B, in] -> [B, out]
  // log N(a; Mean(x), I) summed over dimensions: [B]
  torch::Tensor LogProb(const torch::Tensor& x, const torch::Tensor& a);

  OgMlp backbone{nullptr};          // "backbone"
  torch::nn::Linear head{nullptr};  // "head"
};
TORCH_MODULE(GaussianActor);

// OGBench's GCEncoder for image observations, pixels mode only: with
// images = 2 its concat_encoder (the observation's and the goal's images
// stacked on channels), with images = 1 its state_encoder (the observation's
// alone, as HIQL's value and low actor read it); then a CNN (network.cnn) with
// out_dim features.
class PairEncoderImpl : public torch::nn::Module {
 public:
  PairEncoderImpl(const NetworkOptions& n, int64_t out_dim, int images = 2);
  // obs, goal: [B, H, W, C] uint8 -> [B, out_dim] float32; an encoder of one
  // image takes no goal (an undefined tensor).
  torch::Tensor forward(const torch::Tensor& obs, const torch::Tensor& goal = {});

  ImpalaCnn cnn{nullptr};       // "cnn" (network.cnn = impala)
  LightCnn light_cnn{nullptr};  // "light_cnn" (network.cnn = light)
  int64_t downsample = 1;
  int images = 2;
};
TORCH_MODULE(PairEncoder);

// log N(a; mean, I) summed over the last dimension.
torch::Tensor StdNormalLogProb(const torch::Tensor& a, const torch::Tensor& mean);
// OGBench's expectile weight |tau - 1(adv < 0)|.
torch::Tensor ExpectileWeight(const torch::Tensor& adv, double expectile);
// Interval quasimetric embedding distance (QRL): x, y [B, latent] viewed as
// [B, C, k]; per component the length of the union of the intervals
// [x_j, y_j] over the j with x_j < y_j; mixed as a * mean_c + (1 - a) *
// max_c with a = sigmoid(alpha_raw). Returns [B].
torch::Tensor IqeDistance(const torch::Tensor& x, const torch::Tensor& y, int64_t k,
                          const torch::Tensor& alpha_raw);

// What the six baseline agents share: a training step is one Adam step on
// Loss over a batch of BatchSampler::SampleOgbenchTransitions (under
// trainer.precision) followed by UpdateTargets and, with trainer.policy_ema,
// UpdatePolicyAverage; checkpoints and exports hold the whole agent under the
// key "agent" and its optimiser under "agent_opt". With trainer.policy_ema a
// checkpoint also holds the average of each acting network under "ema_" +
// its name ("ema_actor"; HIQL: "ema_low_actor", "ema_high_actor"), and the
// export's "agent" is the agent with its acting networks replaced by the
// averages (the raw export: the agent itself).
class OgbenchAgent : public GcAgent {
 public:
  explicit OgbenchAgent(const MsprOptions& options);
  ~OgbenchAgent() override;

  // The sum of the agent's losses on a batch of
  // BatchSampler::SampleOgbenchTransitions (ret = reward, discount = gamma *
  // mask). Fills `info` (LossNames order) when not null.
  virtual torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) = 0;
  // How many steps ahead the batch's subgoals lie (HIQL's k; 0: the agent
  // needs none, and the trainer samples no subgoals).
  virtual int SubgoalSteps() const { return 0; }
  // Parameters the optimiser updates (targets excluded).
  std::vector<torch::Tensor> TrainableParameters();
  // The target networks (empty when none), for checks.
  virtual std::vector<torch::nn::Module*> Targets() { return {}; }
  // Moves the agent to `device` and builds its optimiser (MakeGcAgent), and
  // with trainer.policy_ema the averages of the acting networks (copies of
  // them; torch's generator is left as it was).
  void PrepareTraining(torch::Device device);
  // The acting networks by their registered names: what Act reads and
  // trainer.policy_ema averages (the actor; HIQL: low_actor, high_actor).
  virtual std::vector<std::pair<std::string, GaussianActor>> ActingNetworks() = 0;
  // The moving average of acting network `name` (a null holder without
  // trainer.policy_ema, and in an agent built for acting).
  GaussianActor PolicyAverage(const std::string& name) const;
  // One step of the moving average after training step `step` (1 in the
  // first): avg = d avg + (1 - d) w with d = min(trainer.policy_ema,
  // step / (step + 1)), w the weights after the step's update; so until
  // step d / (1 - d) the average is the plain mean of the initial weights and
  // every step's. A no-op without trainer.policy_ema.
  void UpdatePolicyAverage(int64_t step);

  // GcAgent. UpdateTargets: the Polyak update of the target networks
  // (none for gcbc, qrl, crl). Act: the mean action clipped to [-1, 1].
  // Value [B, 2] (two heads, or one repeated): Q ensembles for gciql;
  // V(s, g) for gcivl and hiql (the action is ignored); -d(s', g) with the
  // latent dynamics for qrl; the contrastive logit for crl; none for gcbc.
  // Only gcivl, gciql and hiql are in return units.
  LossInfo Step(TrainingContext& context, bool collect_info) override;
  LossInfo ValidationLosses(BatchSource& batches) override;
  NamedModules CheckpointModules() override;
  NamedOptimizers Optimizers() override { return {{"agent_opt", optimizer_.get()}}; }
  NamedModules PolicyModules(bool raw) override;
  bool HasRawPolicy() const override { return !average_.empty(); }
  // A trainer checkpoint of a run with trainer.policy_ema gives the acting
  // networks' averages, as the run's exports do.
  void ReadPolicy(torch::serialize::InputArchive& archive, bool trainer_checkpoint) override;

 protected:
  // The network Act runs for acting network `online`: its average when there
  // is one, else `online`.
  GaussianActor& ForActing(GaussianActor& online);
  // Polyak average target <- tau * online + (1 - tau) * target.
  void Polyak(torch::nn::Module& target, const torch::nn::Module& online);
  // A target network starts as a copy of its online network and takes no gradient.
  static void InitTarget(torch::nn::Module& target, const torch::nn::Module& online);
  // concat[a, b] along the last dimension.
  static torch::Tensor Cat(const torch::Tensor& a, const torch::Tensor& b);
  // What a network reads of an (observation, goal) pair: [s, g] (states;
  // `encoder` is null), or encoder(s, g) (pixels): [B, pair_dim_].
  static torch::Tensor Pair(PairEncoder& encoder, const torch::Tensor& obs,
                            const torch::Tensor& goal);
  // A new encoder of `images` images (the observation's, and with 2 the
  // goal's) registered as `name` in pixels mode; null for states.
  PairEncoder RegisterPairEncoder(const std::string& name, int images = 2);
  // The observation's features: its encoder's (pixels) or the state itself.
  static torch::Tensor Features(PairEncoder& encoder, const torch::Tensor& obs);
  // MLP sizes {in, hidden x layers, out}.
  std::vector<int64_t> Sizes(int64_t in, int64_t out) const;
  // The DDPG+BC actor loss shared by gciql, qrl and crl:
  // -E[q] / sg(E|q| + 1e-6) - alpha * E[log pi(a | s, g)].
  torch::Tensor DdpgBcLoss(const torch::Tensor& q, const torch::Tensor& log_prob,
                           NamedValues* info);

  int64_t obs_dim_, action_dim_;
  bool pixels_;
  // The width of Pair(): 2 obs_dim (states) or baseline.hidden (pixels).
  int64_t pair_dim_;

 private:
  bool bf16() const { return EffectivePrecision(options_.trainer) == "bf16"; }

  // OGBench: one Adam (no weight decay) over the trainable parameters.
  std::unique_ptr<torch::optim::Adam> optimizer_;
  torch::Device device_ = torch::kCPU;
  // bf16 on the CPU: the weights' bfloat16 copies, cast once per update.
  std::unique_ptr<internal::Bf16WeightCache> weight_cache_;
  // trainer.policy_ema: (name, online, average) per acting network.
  struct Averaged {
    std::string name;
    GaussianActor online, average;
  };
  std::vector<Averaged> average_;
  // The averaged export's "agent": this agent's parameters and modules with
  // the acting networks replaced by their averages (rebuilt by PolicyModules).
  std::shared_ptr<torch::nn::Module> policy_view_;
};

// The former name of OgbenchAgent (before Ms.PR implemented GcAgent too).
using GcAgentImpl = OgbenchAgent;

// Builds the agent named by options.baseline.agent (not "mspr") on the CPU.
// Throws OptionsError for an unknown name, or pixels for an agent that takes
// states only (QRL, CRL, HIQL).
std::shared_ptr<OgbenchAgent> MakeAgent(const MsprOptions& options);

// --- The agents (public for tests) --------------------------------------------

// The agents with one actor pi(a | [s, g]) (all but HIQL): they act with its
// mean, clipped to [-1, 1].
class GcActorAgent : public OgbenchAgent {
 public:
  using OgbenchAgent::OgbenchAgent;
  torch::Tensor Act(const torch::Tensor& obs, const torch::Tensor& goal) override;
  std::vector<std::pair<std::string, GaussianActor>> ActingNetworks() override {
    return {{"actor", actor}};
  }

  GaussianActor actor{nullptr};    // "actor": pi(a | [s, g])
  PairEncoder actor_enc{nullptr};  // "actor_enc": the actor's encoder (pixels)

 protected:
  // Builds and registers `actor` (and, for pixels, `actor_enc`); each
  // constructor calls it last, after the value networks (their
  // initialisation draws come first).
  void RegisterActor();
};

class GcbcAgent : public GcActorAgent {
 public:
  explicit GcbcAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override { return {"actor", "mse"}; }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  bool has_value() const override { return false; }
};

class GcivlAgent : public GcActorAgent {
 public:
  explicit GcivlAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override { return {"value", "v", "actor", "adv"}; }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  void UpdateTargets() override;
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;
  std::vector<torch::nn::Module*> Targets() override;

  OgMlp v1{nullptr}, v2{nullptr};                // V_e([s, g])
  OgMlp target_v1{nullptr}, target_v2{nullptr};  // Polyak copies
  // Pixels: the encoder both heads read, and its Polyak copy.
  PairEncoder value_enc{nullptr}, target_value_enc{nullptr};
};

class GciqlAgent : public GcActorAgent {
 public:
  explicit GciqlAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override {
    return {"value", "critic", "q", "actor", "q_loss", "bc"};
  }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  void UpdateTargets() override;
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;
  std::vector<torch::nn::Module*> Targets() override;
  // [B, 2]: Q_1, Q_2 of ([s, g, a]).
  torch::Tensor Q(const torch::Tensor& obs, const torch::Tensor& goal, const torch::Tensor& action);

  OgMlp v{nullptr};                              // V([s, g])
  OgMlp q1{nullptr}, q2{nullptr};                // Q_e([s, g, a])
  OgMlp target_q1{nullptr}, target_q2{nullptr};  // Polyak copies
  // Pixels: V's encoder; the critic's (both Q heads read it) and its Polyak copy.
  PairEncoder value_enc{nullptr}, critic_enc{nullptr}, target_critic_enc{nullptr};

 private:
  // [B, 2] Q heads of (encoder or [s, g], a): online or target.
  torch::Tensor QOf(bool target, const torch::Tensor& obs, const torch::Tensor& goal,
                    const torch::Tensor& action);
};

class QrlAgent : public GcActorAgent {
 public:
  explicit QrlAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override {
    return {"value", "d_neg", "d_pos", "constraint", "lambda", "dyn", "actor", "q_loss", "bc"};
  }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;
  // The quasimetric between latents: [B, latent] x2 -> [B].
  torch::Tensor Distance(const torch::Tensor& zx, const torch::Tensor& zy);
  // phi(s) + f([phi(s), a]).
  torch::Tensor PredictLatent(const torch::Tensor& z, const torch::Tensor& action);

  OgMlp phi{nullptr};        // the encoder of states and goals
  OgMlp dynamics{nullptr};   // f([z, a]) -> latent residual
  torch::Tensor alpha_raw;   // IQE mix sigmoid(alpha_raw), init 0
  torch::Tensor log_lambda;  // Lagrange multiplier, init 0
};

class CrlAgent : public GcActorAgent {
 public:
  explicit CrlAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override {
    return {"critic", "logits_pos", "logits_neg", "accuracy", "actor", "q_loss", "bc"};
  }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;
  // All pairs' logits of ensemble member e: [B, B], row i = (s_i, a_i), column j = g_j.
  torch::Tensor PairLogits(int e, const torch::Tensor& obs, const torch::Tensor& action,
                           const torch::Tensor& goal);

  OgMlp phi1{nullptr}, phi2{nullptr};  // phi_e([s, a])
  OgMlp psi1{nullptr}, psi2{nullptr};  // psi_e(g)
};

class HiqlAgent : public OgbenchAgent {
 public:
  explicit HiqlAgent(const MsprOptions& o);
  std::vector<std::string> LossNames() const override {
    return {"value", "v", "low_actor", "high_actor", "low_adv", "high_adv"};
  }
  torch::Tensor Loss(const TransitionBatch& batch, NamedValues* info) override;
  void UpdateTargets() override;
  torch::Tensor Act(const torch::Tensor& obs, const torch::Tensor& goal) override;
  // Acting runs the high actor, then the low actor on its length-normalised
  // output (not goal_rep): these two are averaged.
  std::vector<std::pair<std::string, GaussianActor>> ActingNetworks() override {
    return {{"low_actor", low_actor}, {"high_actor", high_actor}};
  }
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;
  std::vector<torch::nn::Module*> Targets() override;
  int SubgoalSteps() const override { return options_.baseline.subgoal_steps; }
  // phi([s; g]) length-normalised to sqrt(rep_dim): [B, rep_dim].
  torch::Tensor GoalRep(const torch::Tensor& obs, const torch::Tensor& goal);
  // [B, 2] V_e(s, phi([s; g])) of the online (target = false) or target heads.
  torch::Tensor V(const torch::Tensor& obs, const torch::Tensor& goal, bool target);

  OgMlp goal_rep{nullptr};                       // phi, shared by V, target V and the low actor
  OgMlp v1{nullptr}, v2{nullptr};                // V_e([s, rep])
  OgMlp target_v1{nullptr}, target_v2{nullptr};  // Polyak copies of the heads only
  GaussianActor low_actor{nullptr};              // pi_l(a | [s, rep(s, w)])
  GaussianActor high_actor{nullptr};             // pi_h(z | [s, g])
  // Pixels, as OGBench's visual HIQL: phi reads a CNN of [s; g] (goal_rep_enc);
  // V, its target and the low actor each read their own CNN of s beside phi;
  // the high actor reads a CNN of [s; g]. Null for states.
  PairEncoder goal_rep_enc{nullptr}, value_enc{nullptr}, target_value_enc{nullptr};
  PairEncoder low_actor_enc{nullptr}, high_actor_enc{nullptr};
};

}  // namespace core
}  // namespace msspr
