#include "msspr_core/options.h"

#include <dirent.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <string>
#include <vector>

#include "test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::TempDir;
using testing_util::WriteText;

TEST(OptionsTest, DefaultsFollowMethodMd) {
  const MsprOptions o = MakePreset("mspr", "paper");
  EXPECT_EQ(o.network.zs_dim, 512);
  EXPECT_EQ(o.network.za_dim, 256);
  EXPECT_EQ(o.network.zsa_dim, 512);
  EXPECT_EQ(o.network.goal_dim, 128);
  EXPECT_EQ(o.network.num_bins, 21);
  EXPECT_EQ(o.network.goal_horizon, 5);
  EXPECT_EQ(o.representation.horizon, 5);
  EXPECT_DOUBLE_EQ(o.representation.weight_dyn, 1.0);
  EXPECT_DOUBLE_EQ(o.representation.weight_rew, 0.3);
  EXPECT_DOUBLE_EQ(o.representation.weight_inv, 0.1);
  EXPECT_DOUBLE_EQ(o.representation.weight_goal_dyn, 0.1);
  EXPECT_DOUBLE_EQ(o.representation.weight_goal_act, 0.1);
  EXPECT_DOUBLE_EQ(o.representation.lr, 1e-4);
  EXPECT_DOUBLE_EQ(o.agent.lr, 3e-4);
  EXPECT_DOUBLE_EQ(o.agent.weight_decay, 1e-4);
  EXPECT_DOUBLE_EQ(o.agent.gamma, 0.99);
  EXPECT_EQ(o.agent.n_step, 3);
  EXPECT_DOUBLE_EQ(o.agent.target_noise, 0.2);
  EXPECT_DOUBLE_EQ(o.agent.target_noise_clip, 0.1);
  EXPECT_EQ(o.agent.target_update_every, 250);
  EXPECT_FALSE(o.agent.critic_grad_to_encoder);
  EXPECT_DOUBLE_EQ(o.relabel.value_p_curgoal, 0.2);
  EXPECT_DOUBLE_EQ(o.relabel.value_p_trajgoal, 0.5);
  EXPECT_DOUBLE_EQ(o.relabel.value_p_randomgoal, 0.3);
  EXPECT_EQ(o.trainer.batch_size, 1024);
  const MsprOptions c = MakePreset("mspr", "cpu");
  EXPECT_EQ(c.network.zs_dim, 256);
  EXPECT_EQ(c.network.goal_dim, 64);
  EXPECT_LE(c.trainer.batch_size, 256);
}

// Everything but the representation loss weights, as YAML.
std::string WithoutLossWeights(MsprOptions o) {
  o.representation.weight_dyn = o.representation.weight_rew = o.representation.weight_inv =
      o.representation.weight_goal_dyn = o.representation.weight_goal_act = 0.0;
  return OptionsToYaml(o);
}

TEST(OptionsTest, AblationPresetsDifferOnlyInLossWeights) {
  for (const std::string& scale : ScaleNames()) {
    const MsprOptions full = MakePreset("mspr", scale);
    for (const char* name : {"mspr", "D", "DI", "DIR"}) {
      const MsprOptions p = MakePreset(name, scale);
      EXPECT_EQ(WithoutLossWeights(p), WithoutLossWeights(full)) << name << " " << scale;
    }
    const auto& d = MakePreset("D", scale).representation;
    EXPECT_GT(d.weight_dyn, 0);
    EXPECT_EQ(d.weight_inv + d.weight_rew + d.weight_goal_dyn + d.weight_goal_act, 0);
    const auto& di = MakePreset("DI", scale).representation;
    EXPECT_GT(di.weight_inv, 0);
    EXPECT_EQ(di.weight_rew + di.weight_goal_dyn + di.weight_goal_act, 0);
    const auto& dir = MakePreset("DIR", scale).representation;
    EXPECT_GT(dir.weight_rew, 0);
    EXPECT_EQ(dir.weight_goal_dyn + dir.weight_goal_act, 0);
    const auto& m = full.representation;
    EXPECT_GT(m.weight_goal_dyn, 0);
    EXPECT_GT(m.weight_goal_act, 0);
  }
  // PresetNames lists them, and the baseline agents after them.
  const std::vector<std::string> names = PresetNames();
  EXPECT_EQ(std::vector<std::string>(names.begin(), names.begin() + 4),
            (std::vector<std::string>{"mspr", "D", "DI", "DIR"}));
  EXPECT_EQ(names.size(), 10u);
  EXPECT_THROW(MakePreset("DIRX", "cpu"), OptionsError);
  EXPECT_THROW(MakePreset("mspr", "tiny"), OptionsError);
}

TEST(OptionsTest, YamlRoundTrip) {
  MsprOptions o = MakePreset("DI", "cpu");
  o.network.obs_dim = 7;
  o.agent.gamma = 0.995;
  o.representation.lr = 1.2345678901234567e-4;
  o.trainer.seed = 1234567890123ULL;
  o.trainer.device = "cuda:1";
  const MsprOptions back = ApplyOptionsYaml(OptionsToYaml(o), MsprOptions());
  EXPECT_EQ(OptionsToYaml(back), OptionsToYaml(o));
  EXPECT_EQ(back.representation.lr, o.representation.lr);
  EXPECT_EQ(back.trainer.seed, o.trainer.seed);
}

TEST(OptionsTest, UnknownKeyNamesFileAndKey) {
  TempDir dir;
  const std::string path = dir.File("bad.yaml");
  WriteText(path, "network:\n  zs_dim: 64\n  hiden_dim: 3\n");
  try {
    LoadOptionsFile(path, MsprOptions());
    FAIL() << "no exception";
  } catch (const OptionsError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("network.hiden_dim"), std::string::npos) << e.what();
  }
  WriteText(path, "netwrk:\n  zs_dim: 64\n");
  try {
    LoadOptionsFile(path, MsprOptions());
    FAIL() << "no exception";
  } catch (const OptionsError& e) {
    EXPECT_NE(std::string(e.what()).find("netwrk"), std::string::npos) << e.what();
  }
  WriteText(path, "agent:\n  gamma: high\n");
  try {
    LoadOptionsFile(path, MsprOptions());
    FAIL() << "no exception";
  } catch (const OptionsError& e) {
    EXPECT_NE(std::string(e.what()).find("agent.gamma"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(LoadOptionsFile(dir.File("missing.yaml"), MsprOptions()), OptionsError);
}

TEST(OptionsTest, OverridesApplyOnTopOfPreset) {
  const MsprOptions o =
      ApplyOptionsYaml("preset: DIR\nscale: cpu\nagent:\n  bc_weight: 0.01\n", MsprOptions());
  EXPECT_EQ(o.network.zs_dim, 256);
  EXPECT_DOUBLE_EQ(o.agent.bc_weight, 0.01);
  EXPECT_EQ(o.representation.weight_goal_act, 0.0);
}

// Layering (ResolveOptions, as msspr_train --preset/--scale/--config uses it).
TEST(OptionsTest, YamlPrintsTheShortestFloatThatReadsBackExactly) {
  MsprOptions o = MakePreset("mspr", "cpu");
  o.representation.weight_rew = 0.3;
  o.agent.bc_weight = 0.1 + 0.2;  // 0.30000000000000004: needs all 17 digits
  o.agent.gamma = 0.995;
  const std::string yaml = OptionsToYaml(o);
  EXPECT_NE(yaml.find("weight_rew: 0.3\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("gamma: 0.995\n"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("0.29999"), std::string::npos) << yaml;
  const MsprOptions back = ApplyOptionsYaml(yaml, MsprOptions());
  EXPECT_EQ(back.agent.bc_weight, 0.1 + 0.2);
  EXPECT_EQ(back.representation.weight_rew, 0.3);
  EXPECT_EQ(back.agent.gamma, 0.995);
}

TEST(OptionsTest, ExplicitPresetWinsOverTheConfigsPreset) {
  TempDir dir;
  const std::string task = dir.File("task.yaml");
  WriteText(task, "preset: mspr\nscale: cpu\nagent:\n  bc_weight: 0.02\n");
  std::vector<std::string> notes;
  const MsprOptions o = ResolveOptions("D", "", {task}, &notes);
  const MsprOptions d = MakePreset("D", "cpu");
  EXPECT_EQ(o.representation.weight_rew, d.representation.weight_rew);
  EXPECT_EQ(o.representation.weight_inv, 0.0);
  EXPECT_EQ(o.representation.weight_goal_act, 0.0);
  EXPECT_EQ(o.network.zs_dim, 256);  // the file's scale: cpu still applies
  EXPECT_DOUBLE_EQ(o.agent.bc_weight, 0.02);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("--preset D overrides 'preset: mspr'"), std::string::npos) << notes[0];
  // An explicit scale wins too.
  notes.clear();
  EXPECT_EQ(ResolveOptions("", "paper", {task}, &notes).network.zs_dim,
            MakePreset("mspr", "paper").network.zs_dim);
  EXPECT_EQ(notes.size(), 1u);
}

TEST(OptionsTest, ConfigsLayerInOrderWithoutResettingEachOther) {
  TempDir dir;
  const std::string a = dir.File("a.yaml"), b = dir.File("b.yaml"), c = dir.File("c.yaml");
  WriteText(a, "scale: cpu\nagent:\n  bc_weight: 0.02\ntrainer:\n  batch_size: 64\n");
  WriteText(b, "preset: DIR\ntrainer:\n  batch_size: 32\n");  // names a preset
  WriteText(c, "trainer:\n  steps: 7\n");
  const MsprOptions o = ResolveOptions("", "", {a, b, c});
  EXPECT_EQ(o.network.zs_dim, 256);           // a's scale
  EXPECT_DOUBLE_EQ(o.agent.bc_weight, 0.02);  // a's key survives b's preset
  EXPECT_EQ(o.trainer.batch_size, 32);        // b overrides a key by key
  EXPECT_EQ(o.trainer.steps, 7);
  EXPECT_EQ(o.representation.weight_goal_act, 0.0);  // DIR
  EXPECT_GT(o.representation.weight_rew, 0.0);
  // No preset anywhere: the defaults (mspr, paper).
  const MsprOptions plain = ResolveOptions("", "", {c});
  EXPECT_EQ(plain.network.zs_dim, MakePreset("mspr", "paper").network.zs_dim);
  EXPECT_EQ(plain.representation.weight_goal_act,
            MakePreset("mspr", "paper").representation.weight_goal_act);
  // A bad name in a file names the file.
  const std::string bad = dir.File("bad.yaml");
  WriteText(bad, "preset: DX\n");
  try {
    ResolveOptions("", "", {a, bad});
    ADD_FAILURE() << "no error";
  } catch (const OptionsError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
}

TEST(OptionsTest, ShippedTaskConfigsNameNoPreset) {
  // Only the ablation configs choose a preset; a task config under --preset D
  // must not bring the full model back.
  const std::string root = MSSPR_CONFIG_DIR;
  DIR* d = opendir(root.c_str());
  ASSERT_NE(d, nullptr) << root;
  int checked = 0;
  while (dirent* e = readdir(d)) {
    const std::string name = e->d_name;
    if (name.size() < 5 || name.substr(name.size() - 5) != ".yaml") continue;
    const YAML::Node y = YAML::LoadFile(root + "/" + name);
    if (name.rfind("ablation_", 0) == 0) {
      EXPECT_TRUE(y["preset"].IsDefined()) << name;
    } else if (name.rfind("eval_tasks", 0) != 0) {
      EXPECT_FALSE(y["preset"].IsDefined()) << name << " names a preset";
      ++checked;
    }
  }
  closedir(d);
  EXPECT_GT(checked, 5);
}

TEST(OptionsTest, ValidateRejectsBadValues) {
  MsprOptions o = MakePreset("mspr", "cpu");
  o.network.obs_dim = 2;
  o.network.action_dim = 2;
  EXPECT_NO_THROW(ValidateOptions(o));
  MsprOptions bad = o;
  bad.relabel.value_p_curgoal = 0.5;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.network.obs_mode = "lidar";
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.network.policy_inputs = "both";
  EXPECT_NO_THROW(ValidateOptions(bad));
  bad.network.policy_inputs = "states";
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad.network.policy_inputs = "raw";
  bad.network.obs_mode = "pixels";  // raw inputs are states
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.agent.gamma = 1.0;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.agent.actor_loss = "awr";
  EXPECT_NO_THROW(ValidateOptions(bad));
  bad.agent.actor_loss = "sac";
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad.agent.actor_loss = "awr";
  bad.agent.awr_temperature = -1.0;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.agent.subgoal_steps = 25;
  EXPECT_NO_THROW(ValidateOptions(bad));
  bad.agent.subgoal_steps = -1;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad.agent.subgoal_steps = 25;
  bad.network.obs_mode = "pixels";  // the subgoal actor proposes a state
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.agent.subgoal_steps = 25;
  bad.agent.subgoal_temperature = -1.0;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad = o;
  bad.trainer.policy_ema = 1.0;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad.trainer.policy_ema = -0.1;
  EXPECT_THROW(ValidateOptions(bad), OptionsError);
  bad.trainer.policy_ema = 0.999;
  EXPECT_NO_THROW(ValidateOptions(bad));
  // The baselines average their actors, and take bf16, as Ms.PR does.
  for (const char* agent : {"gcbc", "gcivl", "gciql", "qrl", "crl", "hiql"}) {
    SCOPED_TRACE(agent);
    MsprOptions b = MakePreset(agent, "cpu");
    b.network.obs_dim = 4;
    b.network.action_dim = 2;
    b.trainer.policy_ema = 0.999;
    b.trainer.precision = "bf16";
    EXPECT_NO_THROW(ValidateOptions(b));
    b.trainer.policy_ema = 1.0;
    EXPECT_THROW(ValidateOptions(b), OptionsError);
    b.trainer.policy_ema = 0.0;
    b.trainer.precision = "auto";
    EXPECT_NO_THROW(ValidateOptions(b));
    b.trainer.precision = "fp16";
    EXPECT_THROW(ValidateOptions(b), OptionsError);
    b.trainer.precision = "auto";
    b.agent.subgoal_steps = 25;  // Ms.PR's subgoal policy; HIQL has its own
    EXPECT_THROW(ValidateOptions(b), OptionsError);
  }
}

// Every options file under config/, config/agents/ (the baselines' layers) and
// config/grids/layers/ (the comparison grids' layers) loads and validates.
TEST(OptionsTest, EveryShippedConfigAndAgentLayerLoads) {
  for (const std::string sub : {"", "/agents", "/grids/layers"}) {
    const std::string dir = std::string(MSSPR_CONFIG_DIR) + sub;
    SCOPED_TRACE(dir);
    std::vector<std::string> files;
    DIR* d = opendir(dir.c_str());
    ASSERT_NE(d, nullptr) << dir;
    while (dirent* e = readdir(d)) {
      const std::string name = e->d_name;
      if (name.size() > 5 && name.substr(name.size() - 5) == ".yaml") files.push_back(name);
    }
    closedir(d);
    std::sort(files.begin(), files.end());
    int loaded = 0;
    for (const std::string& f : files) {
      SCOPED_TRACE(f);
      // config/ also holds other components' files (e.g. evaluation task
      // lists): a file is an options file when a top-level key is one of ours.
      const YAML::Node root = YAML::LoadFile(dir + "/" + f);
      bool ours = false;
      for (const char* key : {"preset", "scale", "network", "representation", "agent", "relabel",
                              "trainer", "baseline"}) {
        ours |= root.IsMap() && root[key].IsDefined();
      }
      if (!ours) continue;
      ++loaded;
      MsprOptions o;
      ASSERT_NO_THROW(o = LoadOptionsFile(dir + "/" + f, MsprOptions()));
      o.network.obs_dim = 4;  // from the data at training time
      o.network.action_dim = 2;
      EXPECT_NO_THROW(ValidateOptions(o));
    }
    // config/ has the presets and layers; config/agents/ the baselines' 8 layers;
    // config/grids/layers/ 4.
    EXPECT_GE(loaded, sub.empty() ? 20 : sub == "/agents" ? 8 : 4);
  }
}

}  // namespace
}  // namespace core
}  // namespace msspr
