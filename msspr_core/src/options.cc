#include "msspr_core/options.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "msspr_core/cpu_info.h"
#include "yaml_sections.h"

namespace msspr {
namespace core {
namespace {

void Require(bool ok, const std::string& what) {
  if (!ok) throw OptionsError("invalid options: " + what);
}

}  // namespace

std::vector<std::string> AgentNames() {
  return {"mspr", "gcbc", "gcivl", "gciql", "qrl", "crl", "hiql"};
}

bool AgentTakesImages(const std::string& agent) {
  return agent == "mspr" || agent == "gcbc" || agent == "gcivl" || agent == "gciql" ||
         agent == "hiql";
}

std::string ImageBaselinesText() { return "gcbc, gcivl, gciql and hiql"; }

std::vector<std::string> PresetNames() {
  std::vector<std::string> names{"mspr", "D", "DI", "DIR"};
  const std::vector<std::string> agents = AgentNames();
  names.insert(names.end(), agents.begin() + 1, agents.end());
  return names;
}

namespace {

bool IsBaseline(const std::string& name) {
  const std::vector<std::string> agents = AgentNames();
  return name != "mspr" && std::find(agents.begin(), agents.end(), name) != agents.end();
}

// OGBench's settings of a baseline agent for the point mazes
// (OGBench's impls/agents: goal sampling, expectile, alpha).
void ApplyBaselinePreset(const std::string& name, MsprOptions& o) {
  BaselineOptions& b = o.baseline;
  RelabelOptions& l = o.relabel;
  b.agent = name;
  // Value goals 0.2 / 0.5 geometric / 0.3, actor goals uniform future states.
  l = RelabelOptions();
  o.agent.gamma = 0.99;
  o.agent.n_step = 1;
  if (name == "gcbc") {
    b.alpha = 0.0;
  } else if (name == "gcivl") {
    b.alpha = 10.0;
    b.expectile = 0.9;
  } else if (name == "gciql") {
    b.alpha = 0.003;
    b.expectile = 0.9;
  } else if (name == "qrl") {
    b.alpha = 0.0003;
    l.value_p_curgoal = 0.0;
    l.value_p_trajgoal = 0.0;
    l.value_p_randomgoal = 1.0;
  } else if (name == "crl") {
    b.alpha = 0.03;
    l.value_p_curgoal = 0.0;
    l.value_p_trajgoal = 1.0;
    l.value_p_randomgoal = 0.0;
    l.value_geom_sample = true;
  } else if (name == "hiql") {
    b.expectile = 0.7;
    b.high_alpha = 3.0;
    b.low_alpha = 3.0;
    b.subgoal_steps = 25;
  }
}

}  // namespace
std::vector<std::string> ScaleNames() { return {"paper", "cpu"}; }

MsprOptions MakePreset(const std::string& preset, const std::string& scale) {
  MsprOptions o;
  if (scale == "paper") {
    // Defaults of the structs are the paper's.
  } else if (scale == "cpu") {
    NetworkOptions& n = o.network;
    n.encoder_hidden = 256;
    n.zs_dim = 256;
    n.za_dim = 128;
    n.zsa_hidden = 256;
    n.zsa_dim = 256;
    n.goal_hidden = 256;
    n.goal_dim = 64;
    n.critic_hidden = 256;
    n.actor_hidden = 256;
    o.trainer.batch_size = 256;
    o.trainer.steps = 20000;
  } else {
    throw OptionsError("unknown scale '" + scale + "' (expected paper or cpu)");
  }
  if (IsBaseline(preset)) {
    ApplyBaselinePreset(preset, o);
    if (scale == "cpu") {
      o.baseline.hidden = 256;
      o.baseline.latent_dim = 256;
    }
    return o;
  }
  RepresentationOptions& r = o.representation;
  if (preset == "mspr") {
  } else if (preset == "D") {
    r.weight_inv = r.weight_rew = r.weight_goal_dyn = r.weight_goal_act = 0.0;
  } else if (preset == "DI") {
    r.weight_rew = r.weight_goal_dyn = r.weight_goal_act = 0.0;
  } else if (preset == "DIR") {
    r.weight_goal_dyn = r.weight_goal_act = 0.0;
  } else {
    throw OptionsError("unknown preset '" + preset +
                       "' (expected mspr, D, DI, DIR, gcbc, gcivl, gciql, qrl, crl or hiql)");
  }
  return o;
}

namespace {

YAML::Node ParseOptionsYaml(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw OptionsError(source + ": YAML parse error: " + e.what());
  }
  if (root && !root.IsNull() && !root.IsMap())
    throw OptionsError(source + ": top level must be a map");
  return root;
}

// The file's `key:` (preset or scale), or "" when it has none.
std::string TopLevelName(const YAML::Node& root, const char* key, const std::string& source) {
  if (!root || root.IsNull() || !root[key]) return "";
  try {
    return root[key].as<std::string>();
  } catch (const YAML::Exception& e) {
    throw OptionsError(source + ": bad " + key + ": " + e.what());
  }
}

// The sections of `root` on top of `o`; preset and scale are accepted and
// left to the caller.
MsprOptions ApplySections(const YAML::Node& root, MsprOptions o, const std::string& source) {
  if (!root || root.IsNull()) return o;
  std::set<std::string> seen{"preset", "scale"};
  ReadSection(root, "network", o.network, source, seen);
  ReadSection(root, "representation", o.representation, source, seen);
  ReadSection(root, "agent", o.agent, source, seen);
  ReadSection(root, "relabel", o.relabel, source, seen);
  ReadSection(root, "trainer", o.trainer, source, seen);
  ReadSection(root, "baseline", o.baseline, source, seen);
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!seen.count(key)) throw OptionsError(source + ": unknown key '" + key + "'");
  }
  return o;
}

MsprOptions PresetFor(const std::string& preset, const std::string& scale,
                      const std::string& source) {
  try {
    return MakePreset(preset, scale);
  } catch (const OptionsError& e) {
    throw OptionsError(source + ": " + e.what());
  }
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw OptionsError(path + ": cannot open options file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

MsprOptions ApplyOptionsYaml(const std::string& yaml_text, const MsprOptions& base,
                             const std::string& source) {
  const YAML::Node root = ParseOptionsYaml(yaml_text, source);
  const std::string preset = TopLevelName(root, "preset", source);
  const std::string scale = TopLevelName(root, "scale", source);
  MsprOptions o = base;
  if (!preset.empty() || !scale.empty()) {
    o = PresetFor(preset.empty() ? "mspr" : preset, scale.empty() ? "paper" : scale, source);
  }
  return ApplySections(root, o, source);
}

MsprOptions ResolveOptions(const std::string& preset, const std::string& scale,
                           const std::vector<std::string>& config_files,
                           std::vector<std::string>* notes, const std::string& default_preset,
                           const std::string& default_scale) {
  std::vector<YAML::Node> roots;
  std::string file_preset, file_scale, preset_source, scale_source;
  for (const std::string& path : config_files) {
    roots.push_back(ParseOptionsYaml(ReadFile(path), path));
    const std::string p = TopLevelName(roots.back(), "preset", path);
    const std::string s = TopLevelName(roots.back(), "scale", path);
    if (!p.empty()) {
      if (!preset.empty() && p != preset && notes) {
        notes->push_back("--preset " + preset + " overrides 'preset: " + p + "' of " + path);
      }
      file_preset = p;
      preset_source = path;
    }
    if (!s.empty()) {
      if (!scale.empty() && s != scale && notes) {
        notes->push_back("--scale " + scale + " overrides 'scale: " + s + "' of " + path);
      }
      file_scale = s;
      scale_source = path;
    }
  }
  const std::string use_preset = !preset.empty()        ? preset
                                 : !file_preset.empty() ? file_preset
                                                        : default_preset;
  const std::string use_scale = !scale.empty()        ? scale
                                : !file_scale.empty() ? file_scale
                                                      : default_scale;
  // An unknown name is reported with the file that gave it, if one did.
  std::string source = "options";
  if (preset.empty() && !preset_source.empty())
    source = preset_source;
  else if (scale.empty() && !scale_source.empty())
    source = scale_source;
  MsprOptions o = PresetFor(use_preset, use_scale, source);
  for (size_t i = 0; i < roots.size(); ++i) o = ApplySections(roots[i], o, config_files[i]);
  return o;
}

MsprOptions LoadOptionsFile(const std::string& path, const MsprOptions& base) {
  return ApplyOptionsYaml(ReadFile(path), base, path);
}

std::string OptionsToYaml(const MsprOptions& options) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  WriteSection(out, "network", options.network);
  WriteSection(out, "representation", options.representation);
  WriteSection(out, "agent", options.agent);
  WriteSection(out, "relabel", options.relabel);
  WriteSection(out, "trainer", options.trainer);
  WriteSection(out, "baseline", options.baseline);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void ValidateOptions(const MsprOptions& o) {
  const NetworkOptions& n = o.network;
  Require(n.obs_mode == "state" || n.obs_mode == "pixels",
          "network.obs_mode must be 'state' or 'pixels', got '" + n.obs_mode + "'");
  Require(n.obs_mode != "state" || n.obs_dim > 0, "network.obs_dim must be > 0 in state mode");
  Require(n.action_dim > 0, "network.action_dim must be > 0");
  Require(n.cnn == "impala" || n.cnn == "light",
          "network.cnn must be 'impala' or 'light', got '" + n.cnn + "'");
  Require(n.image_downsample == 1 || n.image_downsample == 2 || n.image_downsample == 4,
          "network.image_downsample must be 1, 2 or 4");
  // The Impala CNN small is built for 64 x 64; the light CNN for any square
  // image whose side, after downsampling, its three stride-2 layers divide.
  Require(
      n.obs_mode != "pixels" || n.cnn != "impala" || (n.image_height == 64 && n.image_width == 64),
      "network.image_height/width must be 64 for the Impala CNN small (network.cnn: "
      "impala), got " +
          std::to_string(n.image_height) + "x" + std::to_string(n.image_width));
  Require(n.obs_mode != "pixels" || n.cnn != "light" ||
              (n.image_height == n.image_width && n.image_height > 0 &&
               n.image_height % (8 * n.image_downsample) == 0),
          "network.cnn 'light' needs square images whose side is a multiple of 8 x "
          "network.image_downsample, got " +
              std::to_string(n.image_height) + "x" + std::to_string(n.image_width) +
              " with image_downsample " + std::to_string(n.image_downsample));
  Require(n.image_channels > 0 && n.frame_stack > 0,
          "network.image_channels/frame_stack must be > 0");
  Require(n.encoder_hidden > 0 && n.encoder_layers >= 0 && n.zs_dim > 0 && n.za_dim > 0 &&
              n.zsa_hidden > 0 && n.zsa_dim > 0 && n.goal_hidden > 0 && n.goal_dim > 0 &&
              n.critic_hidden > 0 && n.critic_layers > 0 && n.actor_hidden > 0 &&
              n.actor_layers > 0,
          "network widths must be > 0");
  Require(n.num_bins >= 2, "network.num_bins must be >= 2");
  Require(n.goal_horizon >= 1, "network.goal_horizon must be >= 1");
  Require(n.policy_inputs == "latent" || n.policy_inputs == "raw" || n.policy_inputs == "both",
          "network.policy_inputs must be 'latent', 'raw' or 'both', got '" + n.policy_inputs + "'");
  Require(n.policy_inputs == "latent" || n.obs_mode == "state",
          "network.policy_inputs '" + n.policy_inputs +
              "' reads raw states: it needs network.obs_mode 'state'");
  const RepresentationOptions& r = o.representation;
  Require(r.horizon >= 1, "representation.horizon must be >= 1");
  Require(r.reward_loss == "two_hot" || r.reward_loss == "mse",
          "representation.reward_loss must be 'two_hot' or 'mse'");
  Require(r.reward_goals == "all" || r.reward_goals == "trajectory",
          "representation.reward_goals must be 'all' or 'trajectory'");
  Require(r.updates_per_step >= 0, "representation.updates_per_step must be >= 0");
  Require(r.augment_prob >= 0 && r.augment_prob <= 1, "representation.augment_prob in [0, 1]");
  Require(r.augment_pad >= 0 && r.augment_pad < 32,
          "representation.augment_pad must be in [0, 32)");
  const AgentOptions& a = o.agent;
  Require(a.gamma > 0 && a.gamma < 1, "agent.gamma must be in (0, 1)");
  Require(a.n_step >= 1, "agent.n_step must be >= 1");
  Require(a.target_update_every >= 1, "agent.target_update_every must be >= 1");
  Require(a.actor_loss == "ddpg_bc" || a.actor_loss == "awr",
          "agent.actor_loss must be 'ddpg_bc' or 'awr', got '" + a.actor_loss + "'");
  Require(a.awr_temperature >= 0, "agent.awr_temperature must be >= 0");
  Require(a.critic_target == "td3" || a.critic_target == "expectile",
          "agent.critic_target must be 'td3' or 'expectile', got '" + a.critic_target + "'");
  Require(a.expectile > 0 && a.expectile < 1, "agent.expectile must be in (0, 1)");
  Require(a.subgoal_steps >= 0, "agent.subgoal_steps must be >= 0 (0: no subgoal policy)");
  Require(a.subgoal_temperature >= 0, "agent.subgoal_temperature must be >= 0");
  if (a.subgoal_steps > 0) {
    Require(o.network.obs_mode == "state",
            "agent.subgoal_steps needs state observations (the subgoal actor proposes a state)");
    Require(o.baseline.agent == "mspr",
            "agent.subgoal_steps is Ms.PR's subgoal policy; HIQL's is baseline.subgoal_steps");
  }
  const RelabelOptions& l = o.relabel;
  Require(std::abs(l.value_p_curgoal + l.value_p_trajgoal + l.value_p_randomgoal - 1.0) < 1e-6,
          "relabel.value_p_* must sum to 1");
  Require(std::abs(l.actor_p_curgoal + l.actor_p_trajgoal + l.actor_p_randomgoal - 1.0) < 1e-6,
          "relabel.actor_p_* must sum to 1");
  Require(o.trainer.batch_size > 0, "trainer.batch_size must be > 0");
  Require(o.trainer.precision == "fp32" || o.trainer.precision == "bf16" ||
              o.trainer.precision == "auto",
          "trainer.precision must be 'fp32', 'bf16' or 'auto', got '" + o.trainer.precision + "'");
  Require(o.trainer.pipeline == "auto" || o.trainer.pipeline == "on" || o.trainer.pipeline == "off",
          "trainer.pipeline must be 'auto', 'on' or 'off', got '" + o.trainer.pipeline + "'");
  Require(o.trainer.policy_ema >= 0 && o.trainer.policy_ema < 1,
          "trainer.policy_ema must be in [0, 1) (0 = off), got " +
              std::to_string(o.trainer.policy_ema));
  const BaselineOptions& b = o.baseline;
  const std::vector<std::string> agents = AgentNames();
  Require(std::find(agents.begin(), agents.end(), b.agent) != agents.end(),
          "baseline.agent must be one of mspr, gcbc, gcivl, gciql, qrl, crl, hiql; got '" +
              b.agent + "'");
  if (b.agent != "mspr") {
    Require(n.obs_mode == "state" || (n.obs_mode == "pixels" && AgentTakesImages(b.agent)),
            "baseline.agent '" + b.agent + "': network.obs_mode '" + n.obs_mode +
                "' is not supported (images: " + ImageBaselinesText() + "; states: every agent)");
    Require(n.obs_mode == "state" || o.trainer.policy_ema == 0,
            "baseline.agent '" + b.agent +
                "': trainer.policy_ema is for state observations (the average would leave out "
                "the actor's image encoder)");
    Require(b.hidden > 0 && b.layers >= 1, "baseline.hidden must be > 0 and baseline.layers >= 1");
    Require(b.lr > 0, "baseline.lr must be > 0");
    Require(b.tau > 0 && b.tau <= 1, "baseline.tau must be in (0, 1]");
    Require(b.alpha >= 0 && b.high_alpha >= 0 && b.low_alpha >= 0,
            "baseline.alpha values must be >= 0");
    Require(b.expectile > 0 && b.expectile < 1, "baseline.expectile must be in (0, 1)");
    Require(b.latent_dim > 0 && b.iqe_dim > 0 && b.latent_dim % b.iqe_dim == 0,
            "baseline.latent_dim must be a positive multiple of baseline.iqe_dim");
    Require(b.qrl_eps > 0, "baseline.qrl_eps must be > 0");
    Require(b.rep_dim > 0, "baseline.rep_dim must be > 0");
    Require(b.subgoal_steps >= 1, "baseline.subgoal_steps must be >= 1");
  }
}

std::string EffectivePrecision(const TrainerOptions& t, std::string* why) {
  if (t.precision != "auto") {
    if (why) *why = "trainer.precision: " + t.precision;
    return t.precision;
  }
  const bool cpu = t.device.rfind("cpu", 0) == 0;
  const CpuInfo& host = HostCpu();
  const bool bf16 = cpu && host.Bf16FasterThanFp32();
  if (why) {
    if (!cpu)
      *why = "auto: fp32 on " + t.device;
    else if (bf16)
      *why = "auto: bf16, this CPU multiplies bfloat16 faster than fp32";
    else if (host.NativeBf16())
      *why =
          "auto: fp32, this CPU has AVX512-BF16 but no AMX: its bfloat16 products are slower "
          "than fp32 ones";
    else
      *why = "auto: fp32, this CPU has no bfloat16 arithmetic";
  }
  return bf16 ? "bf16" : "fp32";
}

}  // namespace core
}  // namespace msspr
