// msspr_train_expert: trains the ant's direction-following locomotion expert
// with soft actor-critic in OGBench's online-ant-xy, by OGBench's recipe
// (docs/ant_mazes.md): 400k environment steps, 10k of them random first, one
// update per step, 256-256 GELU networks, lr 1e-4, batch 256, target entropy
// -4. Resumable: run the same command again to continue from the checkpoint.
#include <torch/torch.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/options.h"
#include "msspr_core/process_env.h"
#include "msspr_core/sac.h"
#include "msspr_core/stop_signals.h"
#include "msspr_eval/ant_expert.h"

namespace {

constexpr const char* kUsage = R"(usage: msspr_train_expert --out DIR [options]
Trains the ant's locomotion expert (a direction-following policy) with soft actor-critic in
OGBench's online-ant-xy. Writes DIR/metrics.csv, DIR/sac_checkpoint.pt (atomic; the same
command resumes from it) and DIR/sac_policy.pt (the actor, for the ant maze's waypoint expert).
  --out DIR            run directory (required)
  --env NAME           ant-xy (the only one; default)
  --steps N            environment steps in all (default 400000)
  --random-steps N     uniform random actions first (default 10000)
  --seed S             seed of torch, the replay sampler and the episodes (default 0)
  --config FILE        YAML with a `sac:` section (msspr_core/sac.h SacOptions) under the flags
  --time-limit S       stop after S seconds of this invocation (a checkpoint is written)
  --eval-every N       deterministic evaluation every N steps (default 50000; 0: never)
  --eval-episodes N    episodes per evaluation (default 5)
  --checkpoint-every N (default 25000)
  --log-every N        metrics.csv row period (default 1000)
  --threads N          torch threads (default 1)
SIGINT (Ctrl-C) or SIGTERM: the run stops after the current step, writes its checkpoint and
exits with 128 + the signal number; the same command continues it.
Example: msspr_train_expert --out runs/ant-expert --seed 0 --time-limit 3600
)";

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  using msspr::cli::CliError;
  msspr::core::SacOptions o;
  std::string out;
  try {
    msspr::cli::CliArgs args(
        argc, argv, {"help"},
        {"out", "env", "steps", "random-steps", "seed", "config", "time-limit", "eval-every",
         "eval-episodes", "checkpoint-every", "log-every", "threads"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw CliError("unexpected argument '" + args.positional()[0] + "'");
    out = args.Get("out", "");
    if (out.empty()) throw CliError("--out is required");
    args.GetChoice("env", "ant-xy", {"ant-xy"});
    o.eval_every = 50000;
    o.checkpoint_every = 25000;
    if (args.Has("config")) {
      const std::string path = args.Get("config", "");
      std::ifstream in(path);
      if (!in) throw CliError("--config " + path + ": cannot be read");
      std::ostringstream text;
      text << in.rdbuf();
      o = msspr::core::ApplySacYaml(text.str(), o, path);
    }
    o.steps = args.GetInt("steps", o.steps, 1);
    o.random_steps = args.GetInt("random-steps", o.random_steps, 0);
    o.seed = static_cast<uint64_t>(args.GetInt("seed", static_cast<long>(o.seed), 0));
    o.time_limit_s = args.GetDouble("time-limit", o.time_limit_s, 0.0);
    o.eval_every = args.GetInt("eval-every", o.eval_every, 0);
    o.eval_episodes = static_cast<int>(args.GetInt("eval-episodes", o.eval_episodes, 1, 10000));
    o.checkpoint_every = args.GetInt("checkpoint-every", o.checkpoint_every, 0);
    o.log_every = static_cast<int>(args.GetInt("log-every", o.log_every, 1));
    torch::set_num_threads(static_cast<int>(args.GetInt("threads", 1, 1, 4096)));
    msspr::core::ValidateSacOptions(o);
  } catch (const std::exception& e) {
    std::cerr << "msspr_train_expert: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    msspr::core::SacTrainer trainer(
        o, [] { return std::make_unique<msspr::agent::AntXyOnlineEnv>(); }, out);
    std::cerr << "msspr_train_expert: ant-xy, SAC " << o.hidden << "x" << o.layers << ", "
              << (trainer.resumed() ? "resuming at step " + std::to_string(trainer.step())
                                    : std::string("from scratch"))
              << ", to " << o.steps << " steps, out " << out << "\n";
    msspr::core::StopOnSignals signals;
    const int64_t steps = trainer.Train(signals.flag());
    if (trainer.stopped()) {
      const int sig = signals.signal();
      std::cerr << "msspr_train_expert: " << (sig == SIGINT ? "SIGINT" : "SIGTERM")
                << ": stopped at step " << steps << "; wrote " << trainer.checkpoint_path()
                << " and " << trainer.policy_path() << "; the same command continues\n";
      return 128 + (sig > 0 ? sig : SIGTERM);
    }
    const double ret = trainer.Evaluate(o.eval_episodes, o.seed + 12345);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "{\"steps\": %lld, \"eval_return\": %.2f, \"eval_episodes\": %d, \"wall_time_s\": %.1f, "
        "\"policy\": \"%s\"}\n",
        static_cast<long long>(steps), ret, o.eval_episodes, wall, trainer.policy_path().c_str());
  } catch (const std::exception& e) {
    std::cerr << "msspr_train_expert: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
