// msspr_eval_oracle: how well the scripted oracle of a manipulation env solves that env's
// evaluation tasks: the episodes of msspr_eval (EvalEpisodeSeed), the oracle instead of a
// policy. A dataset is only as good as the oracle that makes it; this measures it.
#include <algorithm>
#include <chrono>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include "msspr_core/cli_args.h"
#include "msspr_sim/cube_double_oracle.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/puzzle_oracle.h"
#include "msspr_sim/random_util.h"
#include "msspr_sim/scene_oracle.h"

namespace {

constexpr char kUsage[] = R"(usage: msspr_eval_oracle --env ENV [options]
Runs the scripted task oracle on an env's evaluation tasks and prints its success per task:
puzzle-3x3, puzzle-4x4 (PuzzleTaskOracle: presses the fewest-press solution, one button
plan at a time), cube-double (CubeDoubleTaskOracle: one pick and place per cube, parking
one first where needed) and scene (SceneTaskOracle: the cube, then the drawer, the window and
the buttons, unlocking before a slide), with the play data's plan noise.
  --env ENV          puzzle-3x3 | puzzle-4x4 | cube-double | scene (required)
  --episodes N       episodes per task (default 50)
  --tasks LIST       task ids (default 1,2,3,4,5)
  --max-steps N      steps per episode (default: the env's cap, 500; the scene 750)
  --seed S           evaluation seed: the episodes of msspr_eval --seed S (default 0)
  --urdf FILE        the arm (default: the package's msspr_sim/urdf/ur5e_2f85.urdf)
  --out FILE.json    also write the results as JSON
Example:
  rosrun msspr msspr_eval_oracle --env puzzle-3x3 --episodes 50
)";

// The task oracle's episodes of every task of `flags` in `env`.
template <class Oracle, class Env>
std::vector<msspr::sim::TaskResult> RunOracle(Env& env, const msspr::sim::EpisodeFlags& flags,
                                              const std::string& name) {
  namespace sim = msspr::sim;
  std::vector<sim::TaskResult> results;
  for (int task : flags.tasks) {
    sim::TaskResult r;
    r.task_id = task;
    r.episodes = flags.episodes;
    int successes = 0;
    double steps = 0;
    for (int e = 0; e < flags.episodes; ++e) {
      const uint64_t seed = sim::EvalEpisodeSeed(flags.seed, task, e);
      env.ResetToTask(task, seed);
      Oracle oracle(sim::Mix64(seed));
      while (!env.EpisodeOver()) env.Step(oracle.Act(env));
      if (env.Success()) {
        ++successes;
        steps += env.episode_steps();
      }
    }
    r.success = static_cast<double>(successes) / flags.episodes;
    r.mean_steps_successful = successes > 0 ? steps / successes : 0;
    results.push_back(r);
    std::cerr << "[msspr_eval_oracle] " << name << " task " << task << ": " << 100.0 * r.success
              << "% of " << flags.episodes << " episodes\n";
  }
  return results;
}

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  sim::EnvId env_id = sim::EnvId::kPuzzle3x3;
  sim::EpisodeFlags flags;
  std::string urdf, out;
  try {
    const msspr::cli::CliArgs args(
        argc, argv, {"help"}, {"env", "episodes", "tasks", "max-steps", "seed", "urdf", "out"});
    if (args.Has("help") || !args.positional().empty())
      throw msspr::cli::CliError(
          args.Has("help") ? "" : "unexpected argument '" + args.positional()[0] + "'");
    if (!args.Has("env")) throw msspr::cli::CliError("--env is required");
    env_id = sim::ParseEnvId(
        args.GetChoice("env", "",
                       sim::EnvIdNames({sim::EnvId::kPuzzle3x3, sim::EnvId::kPuzzle4x4,
                                        sim::EnvId::kCubeDouble, sim::EnvId::kScene})));
    flags = sim::ReadEpisodeFlags(args, sim::EvalEpisodeCap(env_id), 5);
    urdf = args.Get("urdf", sim::DefaultArmUrdf());
    out = args.Get("out", "");
  } catch (const std::exception& e) {
    if (*e.what()) std::cerr << "msspr_eval_oracle: " << e.what() << "\n";
    std::cerr << kUsage;
    return *e.what() ? 2 : 0;
  }
  try {
    const auto t0 = std::chrono::steady_clock::now();
    sim::EvalReport report;
    report.env = sim::EnvLabel(env_id);
    report.agent = "oracle";
    report.observation_mode = "state";
    report.episodes_per_task = flags.episodes;
    report.max_steps = flags.max_steps;
    report.seed = flags.seed;
    if (sim::IsPuzzle(env_id)) {
      sim::PuzzleEnvOptions opt;
      opt.urdf_path = urdf;
      opt.side = sim::PuzzleSide(env_id);
      opt.max_episode_steps = flags.max_steps;
      sim::PuzzleEnv env(opt);
      report.tasks = RunOracle<sim::PuzzleTaskOracle>(env, flags, report.env);
      for (auto& r : report.tasks) {  // the boards, row by row
        const auto& t = sim::PuzzleTasks(opt.side)[static_cast<size_t>(r.task_id - 1)];
        r.start.assign(t.start.begin(), t.start.end());
        r.goal.assign(t.goal.begin(), t.goal.end());
      }
    } else if (env_id == sim::EnvId::kScene) {
      sim::SceneEnvOptions opt;
      opt.urdf_path = urdf;
      opt.max_episode_steps = flags.max_steps;
      sim::SceneEnv env(opt);
      report.tasks = RunOracle<sim::SceneTaskOracle>(env, flags, report.env);
    } else {
      sim::CubeDoubleEnvOptions opt;
      opt.urdf_path = urdf;
      opt.max_episode_steps = flags.max_steps;
      sim::CubeDoubleEnv env(opt);
      report.tasks = RunOracle<sim::CubeDoubleTaskOracle>(env, flags, report.env);
    }
    report.wall_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sim::FinalizeReport(&report);
    std::cout << sim::EvalReportTable(report);
    if (!out.empty()) sim::WriteTextFile(out, sim::EvalReportJson(report));
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_oracle: error: " << e.what() << "\n";
    return 1;
  }
}
