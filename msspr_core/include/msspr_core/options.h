// Options of every Ms.PR component, with the paper's defaults.
// Each struct lists its fields once in a `Visit` function; the YAML loader,
// the YAML writer and the checkpoint header all go through that list, so a
// field added here is loadable, saved and restored without further code.
// This header does not include torch.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr {
namespace core {

// Thrown for a bad option value, an unknown key or an unknown preset.
class OptionsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Sizes of the networks (the paper's appendix A.2). Dims of the data
// (obs_dim, action_dim, image sizes) are filled from the dataset.
struct NetworkOptions {
  std::string obs_mode = "state";  // "state" (float vector) or "pixels" (uint8 HWC image)
  int obs_dim = 0;                 // state observation size (state mode)
  int action_dim = 0;              // action size, actions in [-1, 1]
  int image_height = 64;           // pixels mode
  int image_width = 64;            // pixels mode
  int image_channels = 3;          // per frame; the CNN sees image_channels * frame_stack
  int frame_stack = 1;             // frames stacked along channels (3 for manipulation)
  std::string cnn = "impala";      // pixels: "impala" (the paper's Impala CNN small) or "light"
                                   // (three stride-2 conv3x3 + ReLU, 16/32/32 channels)
  int image_downsample = 1;        // pixels: average-pool the image by this factor (1, 2 or 4)
  // pixels: LayerNorm over the CNN's flattened features before its linear
  // projection (the MLP block's Pre-LN applied to the projection, which the
  // paper's sketch leaves without one: it bounds the latents' scale).
  bool cnn_feature_norm = false;
  // inside the encoder, before the CNN (the data stays 64x64)
  int encoder_hidden = 512;      // E_s MLP hidden width (state mode)
  int encoder_layers = 2;        // E_s hidden layers
  int zs_dim = 512;              // z_s
  int za_dim = 256;              // z_a (action encoder output)
  int zsa_hidden = 512;          // E_sa hidden width
  int zsa_dim = 512;             // z_sa
  int goal_hidden = 512;         // psi hidden width
  int goal_dim = 128;            // g_rep
  bool length_normalize = true;  // g_rep = x / ||x|| * sqrt(goal_dim)
  int critic_hidden = 512;       // Q hidden width
  int critic_layers = 3;         // Q hidden layers
  int actor_hidden = 512;        // pi hidden width
  int actor_layers = 3;          // pi hidden layers
  int num_bins = 21;             // f_rew two-hot bins over [-1/(1-gamma), 0]
  int goal_horizon = 5;          // k: f_g-dyn predicts z_s(t+k), f_g-act a_t..a_{t+k-1}
  double layer_norm_eps = 1e-6;  // Pre-LN epsilon (paper appendix A.2)
  // What the critic and the actor read (state observations only for raw / both):
  //   "latent" (the paper): Q([z_sa, g_rep]), pi([z_s, g_rep]);
  //   "raw": the raw state, action and goal, Q([s, a, g]), pi([s, g]), as
  //          OGBench's agents (the representation still trains, unread);
  //   "both": the two concatenated, Q([z_sa, g_rep, s, a, g]), pi([z_s, g_rep, s, g]).
  std::string policy_inputs = "latent";

  template <class V>
  void Visit(V& v) {
    v("obs_mode", obs_mode);
    v("obs_dim", obs_dim);
    v("action_dim", action_dim);
    v("image_height", image_height);
    v("image_width", image_width);
    v("image_channels", image_channels);
    v("frame_stack", frame_stack);
    v("cnn", cnn);
    v("image_downsample", image_downsample);
    v("cnn_feature_norm", cnn_feature_norm);
    v("encoder_hidden", encoder_hidden);
    v("encoder_layers", encoder_layers);
    v("zs_dim", zs_dim);
    v("za_dim", za_dim);
    v("zsa_hidden", zsa_hidden);
    v("zsa_dim", zsa_dim);
    v("goal_hidden", goal_hidden);
    v("goal_dim", goal_dim);
    v("length_normalize", length_normalize);
    v("critic_hidden", critic_hidden);
    v("critic_layers", critic_layers);
    v("actor_hidden", actor_hidden);
    v("actor_layers", actor_layers);
    v("num_bins", num_bins);
    v("goal_horizon", goal_horizon);
    v("layer_norm_eps", layer_norm_eps);
    v("policy_inputs", policy_inputs);
  }
};

// Representation loss (Eq. 1) and its optimiser.
struct RepresentationOptions {
  int horizon = 5;                      // H: unroll length of the chunk
  double weight_dyn = 1.0;              // lambda_dyn
  double weight_rew = 0.3;              // lambda_rew (0.5 pixels)
  double weight_inv = 0.1;              // lambda_inv
  double weight_goal_dyn = 0.1;         // lambda_g-dyn (0.3 pixel manipulation)
  double weight_goal_act = 0.1;         // lambda_g-act
  std::string reward_loss = "two_hot";  // "two_hot" (cross-entropy) or "mse" (on the decoded value)
  // Which chunk goals train f_rew: "all" (the paper: a goal outside the
  // chunk's trajectory, or behind it, gets the return -1/(1-gamma)) or
  // "trajectory" (only goals ahead in the chunk's own trajectory, whose
  // return is known; on stitch data most other goals are reachable).
  std::string reward_goals = "all";
  double lr = 1e-4;               // AdamW learning rate of encoders + predictors
  double weight_decay = 1e-4;     // AdamW weight decay
  double updates_per_step = 1.0;  // representation updates per training step (fractions accumulate)
  double augment_prob = 0.0;      // pixels: probability that a batch is augmented (one draw per
                                  // batch, as OGBench); 0.5 for OGBench's visual tasks
  int augment_pad = 3;            // random-shift padding in pixels (edge padding, then a crop;
                                  // one shift per sample, shared by all of the sample's images)

  template <class V>
  void Visit(V& v) {
    v("horizon", horizon);
    v("weight_dyn", weight_dyn);
    v("weight_rew", weight_rew);
    v("weight_inv", weight_inv);
    v("weight_goal_dyn", weight_goal_dyn);
    v("weight_goal_act", weight_goal_act);
    v("reward_loss", reward_loss);
    v("reward_goals", reward_goals);
    v("lr", lr);
    v("weight_decay", weight_decay);
    v("updates_per_step", updates_per_step);
    v("augment_prob", augment_prob);
    v("augment_pad", augment_pad);
  }
};

// Critic (Eq. 2) and actor (Eq. 3).
struct AgentOptions {
  double gamma = 0.99;             // discount (0.995 giant / humanoid mazes)
  int n_step = 3;                  // n-step return, stopped at the first success
  double huber_delta = 1.0;        // Huber loss threshold
  double target_noise = 0.2;       // std of the target policy noise
  double target_noise_clip = 0.1;  // c: noise clipped to [-c, c]
  bool clip_target = true;         // clamp the TD target to [-1/(1-gamma), 0] (the return's range)
  double bc_weight = 0.1;          // lambda_BC: 0.01 pointmaze, 0.1 locomotion, 1.0 manipulation
  double lr = 3e-4;                // AdamW learning rate of critic and actor
  double weight_decay = 1e-4;      // AdamW weight decay
  bool critic_grad_to_encoder = false;  // let the critic loss train the encoders too
  int target_update_every = 250;        // K: hard copy of all target networks
  // The actor's objective: "ddpg_bc" (the paper's Eq. 3: -Q(s, pi) / mean|Q| + bc_weight *
  // ||pi - a||^2) or "awr" (advantage-weighted regression on the critic:
  // mean(min(exp(awr_temperature * (Q(s, a) - Q(s, pi))), 100) * ||pi - a||^2), as OGBench's
  // GCIVL/HIQL weight their actors; bc_weight unused).
  std::string actor_loss = "ddpg_bc";
  double awr_temperature = 10.0;
  // The critic's bootstrap at s_{t+n}: "td3" (the paper's Eq. 2: min of the target
  // critic at the target actor's noisy action) or "expectile" (in-sample, as IQL and
  // OGBench's GCIQL: a value network V(s, g) fit by expectile regression to the target
  // critic at the dataset's actions, so the target never queries an action the data
  // lacks; y = R_n + gamma^n V(s_{t+n}, g)).
  std::string critic_target = "td3";
  double expectile = 0.9;  // tau of the expectile loss (critic_target "expectile")
  // > 0: a subgoal policy, as HIQL's hierarchy (not in the paper; state observations only).
  // The actor learns to reach s_{t+k} (k = subgoal_steps, or the trajectory's end), and a
  // second network, the subgoal actor, learns to propose that state for a far goal g by
  // advantage-weighted regression (weights min(exp(subgoal_temperature * (V(s_{t+k}, g) -
  // V(s_t, g))), 100), V fit by expectile regression as for critic_target "expectile").
  // Acting: a = pi(s, subgoal(s, g)). 0: the paper's single actor.
  int subgoal_steps = 0;
  double subgoal_temperature = 3.0;

  template <class V>
  void Visit(V& v) {
    v("gamma", gamma);
    v("n_step", n_step);
    v("huber_delta", huber_delta);
    v("target_noise", target_noise);
    v("target_noise_clip", target_noise_clip);
    v("clip_target", clip_target);
    v("bc_weight", bc_weight);
    v("lr", lr);
    v("weight_decay", weight_decay);
    v("critic_grad_to_encoder", critic_grad_to_encoder);
    v("target_update_every", target_update_every);
    v("actor_loss", actor_loss);
    v("awr_temperature", awr_temperature);
    v("critic_target", critic_target);
    v("expectile", expectile);
    v("subgoal_steps", subgoal_steps);
    v("subgoal_temperature", subgoal_temperature);
  }
};

// Goal relabelling as OGBench's GCDataset. Proportions of each group must
// sum to 1. Geometric offsets use p = 1 - gamma (AgentOptions::gamma).
struct RelabelOptions {
  double value_p_curgoal = 0.2;     // goal = current state
  double value_p_trajgoal = 0.5;    // goal = future state of the same trajectory
  double value_p_randomgoal = 0.3;  // goal = random dataset state
  bool value_geom_sample = true;    // future offset geometric (true) or uniform (false)
  double actor_p_curgoal = 0.0;
  double actor_p_trajgoal = 1.0;
  double actor_p_randomgoal = 0.0;
  bool actor_geom_sample = false;

  template <class V>
  void Visit(V& v) {
    v("value_p_curgoal", value_p_curgoal);
    v("value_p_trajgoal", value_p_trajgoal);
    v("value_p_randomgoal", value_p_randomgoal);
    v("value_geom_sample", value_geom_sample);
    v("actor_p_curgoal", actor_p_curgoal);
    v("actor_p_trajgoal", actor_p_trajgoal);
    v("actor_p_randomgoal", actor_p_randomgoal);
    v("actor_geom_sample", actor_geom_sample);
  }
};

// The training loop.
struct TrainerOptions {
  int batch_size = 1024;       // 1024 states, 256 pixels
  int64_t steps = 1000000;     // 1M states, 500k pixels
  uint64_t seed = 0;           // seeds torch and the sampler
  std::string device = "cpu";  // "cpu", "cuda", "cuda:1"
  int log_every = 100;         // progress / CSV row period (steps)
  int eval_every = 0;          // evaluator period (steps); 0 = never
  int checkpoint_every = 0;    // checkpoint period (steps); 0 = only at the end
  int export_every = 0;        // period (steps) of extra inference exports
                               // out_dir/policy_step<N>.pt (learning curves); 0 = none
  double time_limit_s = 0;     // stop Train() after this wall time (s) of the run; 0 = none
  // "fp32", "bf16" (matrix products and convolutions in bfloat16 through
  // autocast; LayerNorm, losses and the optimiser in fp32) or "auto": bf16 on
  // a CPU whose bfloat16 products beat its fp32 ones (CpuInfo::
  // Bf16FasterThanFp32: Intel with AMX, AMD with AVX512-BF16), fp32 elsewhere
  // (other CPUs, where bf16 is emulated or slower, and GPUs).
  // EffectivePrecision() resolves it; msspr_train records the result.
  std::string precision = "fp32";
  // "auto", "on" or "off". On the CPU, a step's actor-critic update runs on a
  // second thread beside the next step's representation update (the two read
  // the encoders, only the representation update writes them, after the
  // actor-critic update is done), each with half of torch's threads. The
  // result equals the sequential schedule's. With agent.critic_grad_to_encoder
  // the critic update writes the encoders, so only the actor update and the
  // next step's TD target run beside the representation update. "auto": on for
  // the CPU with 2 or more torch threads.
  std::string pipeline = "auto";
  // > 0: the trainer keeps an exponential moving average of the policy's
  // networks (Ms.PR: encoders and goal head, actor, critic; the baselines:
  // the actor, HIQL's low and high actors) with this decay
  // per step (warm-up: min(decay, t / (t + 1)) at step t, the plain mean of
  // every step's weights until t = decay / (1 - decay)), and the exports
  // (policy.pt, policy_step<N>.pt) and in-training evaluations use the average
  // instead of the raw weights. 0.99995: a plain mean up to 20k steps, then
  // an average over about the last 20k. 0 = off: the raw weights.
  double policy_ema = 0.0;

  template <class V>
  void Visit(V& v) {
    v("batch_size", batch_size);
    v("steps", steps);
    v("seed", seed);
    v("device", device);
    v("log_every", log_every);
    v("eval_every", eval_every);
    v("checkpoint_every", checkpoint_every);
    v("export_every", export_every);
    v("time_limit_s", time_limit_s);
    v("precision", precision);
    v("pipeline", pipeline);
    v("policy_ema", policy_ema);
  }
};

// OGBench's baseline agents (msspr_core/README.md
// "Baselines"). agent "mspr" trains Ms.PR and ignores the rest of this
// section. The baselines use agent.gamma, relabel.*, trainer.batch_size /
// steps / seed / device, network.obs_dim / action_dim (state observations
// only), 1-step targets and one Adam optimiser over the sum of their losses.
struct BaselineOptions {
  std::string agent = "mspr";  // mspr | gcbc | gcivl | gciql | qrl | crl | hiql
  int hidden = 512;            // width of every MLP hidden layer
  int layers = 3;              // hidden layers of every MLP
  double lr = 3e-4;            // Adam learning rate (no weight decay)
  double tau = 0.005;          // Polyak rate of the target networks (gcivl, gciql, hiql)
  double alpha = 0.0;          // AWR temperature (gcivl) or BC coefficient (gciql, qrl, crl)
  double expectile = 0.9;      // expectile of the value loss (gcivl, gciql; hiql 0.7)
  int latent_dim = 512;        // qrl: quasimetric latent; crl: contrastive latent
  int iqe_dim = 8;          // qrl: dimensions per IQE component (latent_dim / iqe_dim components)
  double qrl_eps = 0.05;    // qrl: the constraint E[relu(d(s, s') - 1)^2] <= eps
  int rep_dim = 10;         // hiql: subgoal representation size
  int subgoal_steps = 25;   // hiql: k, the low-level goal s_{t+k} (10 for manipulation)
  double high_alpha = 3.0;  // hiql: AWR temperature of the high-level actor
  double low_alpha = 3.0;   // hiql: AWR temperature of the low-level actor
  bool low_actor_rep_grad =
      false;  // hiql: the low actor's loss also trains the subgoal representation

  template <class V>
  void Visit(V& v) {
    v("agent", agent);
    v("hidden", hidden);
    v("layers", layers);
    v("lr", lr);
    v("tau", tau);
    v("alpha", alpha);
    v("expectile", expectile);
    v("latent_dim", latent_dim);
    v("iqe_dim", iqe_dim);
    v("qrl_eps", qrl_eps);
    v("rep_dim", rep_dim);
    v("subgoal_steps", subgoal_steps);
    v("high_alpha", high_alpha);
    v("low_alpha", low_alpha);
    v("low_actor_rep_grad", low_actor_rep_grad);
  }
};

// Everything; the YAML file has one section per member.
struct MsprOptions {
  NetworkOptions network;
  RepresentationOptions representation;
  AgentOptions agent;
  RelabelOptions relabel;
  TrainerOptions trainer;
  BaselineOptions baseline;
};

// The agents of BaselineOptions::agent: {"mspr", "gcbc", "gcivl", "gciql",
// "qrl", "crl", "hiql"}.
std::vector<std::string> AgentNames();
// The agents that train from images (network.obs_mode: pixels): Ms.PR and the baselines
// with a pair encoder {"gcbc", "gcivl", "gciql"}; QRL, CRL and HIQL take states only.
bool AgentTakesImages(const std::string& agent);
// "gcbc, gcivl, gciql and hiql": the baselines of AgentTakesImages, for messages.
std::string ImageBaselinesText();

// Names accepted by MakePreset: the Ms.PR presets {"mspr", "D", "DI",
// "DIR"} and every baseline agent of AgentNames().
std::vector<std::string> PresetNames();
std::vector<std::string> ScaleNames();  // {"paper", "cpu"}

// Returns the options of a preset ("mspr" full; ablations "D", "DI", "DIR"
// differ only in the representation loss weights) at a scale ("paper": the
// paper's widths and batch; "cpu": widths 256, latent 256, goal 64, batch
// 256). A baseline agent's preset ("gcbc", ..., "hiql") sets
// baseline.agent, its relabelling and OGBench's pointmaze hyperparameters
// (OGBench's settings for it); at the cpu scale its MLPs are 256 wide, its
// latents 256 and its batch 256. Throws OptionsError on an unknown name.
MsprOptions MakePreset(const std::string& preset, const std::string& scale);

// Applies the YAML text on top of `base`. Top-level keys are the sections
// network, representation, agent, relabel, trainer, plus optional `preset`
// and `scale` (which replace `base` by MakePreset(preset, scale) first).
// Throws OptionsError naming `source` and the key on an unknown key or a
// value of the wrong type.
MsprOptions ApplyOptionsYaml(const std::string& yaml_text, const MsprOptions& base,
                             const std::string& source = "<string>");

// Reads a YAML file and applies it on top of `base` (see ApplyOptionsYaml).
// Throws OptionsError naming the file when it cannot be read or parsed.
MsprOptions LoadOptionsFile(const std::string& path, const MsprOptions& base);

// The options of a run from a preset, a scale and config files, layered:
// 1. the preset and the scale: an explicit `preset` / `scale` (non-empty,
//    e.g. from --preset / --scale) wins over the files' `preset:` / `scale:`
//    keys; otherwise the last file naming one gives it; otherwise
//    `default_preset` / `default_scale`;
// 2. MakePreset of those, once;
// 3. every file's sections, in order (a later file overrides an earlier one
//    key by key; a file's preset or scale key never resets what came before).
// `notes` (when not null) receives a line for each file key that an explicit
// preset or scale overrode. Throws OptionsError naming the file.
MsprOptions ResolveOptions(const std::string& preset, const std::string& scale,
                           const std::vector<std::string>& config_files,
                           std::vector<std::string>* notes = nullptr,
                           const std::string& default_preset = "mspr",
                           const std::string& default_scale = "paper");

// Serialises all options as YAML text that ApplyOptionsYaml reads back.
std::string OptionsToYaml(const MsprOptions& options);

// Checks consistency (positive sizes, proportions summing to 1, known
// modes); throws OptionsError naming the field.
void ValidateOptions(const MsprOptions& options);

// "fp32" or "bf16": trainer.precision with "auto" resolved for trainer.device
// on this machine (HostCpu()). why, if given, says what decided it.
std::string EffectivePrecision(const TrainerOptions& trainer, std::string* why = nullptr);

}  // namespace core
}  // namespace msspr
