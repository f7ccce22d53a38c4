// msspr_eval_ant_expert: the ant's direction-following expert (sac_policy.pt of
// msspr_train_expert) with OGBench's BFS waypoint planner, noise-free, on an ant
// maze's five evaluation tasks (the episodes of msspr_eval --seed S). Prints the
// per-task table, the mean success and the torso's mean speed; --out writes the
// results JSON of the other evaluators, with the speed added.
#include <torch/torch.h>

#include <cstdio>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_core/process_env.h"
#include "msspr_core/sac.h"
#include "msspr_eval/ant_waypoint_expert.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/package_files.h"

namespace {

constexpr const char* kUsage =
    R"(usage: msspr_eval_ant_expert [--expert DIR/sac_policy.pt] [options]
Evaluates the ant's locomotion expert with the BFS waypoint planner (noise-free) on an
ant maze's evaluation tasks: success per task, mean success, the torso's mean speed.
  --expert FILE       the expert's actor, sac_policy.pt of msspr_train_expert
                      (default: the shipped msspr_sim/experts/ant_xy_expert.pt)
  --env ENV           antmaze-medium | antmaze-large (default antmaze-medium)
  --tasks LIST        task ids (default 1,2,3,4,5)
  --episodes N        episodes per task (default 50)
  --max-steps N       step limit (default 1000)
  --seed S            evaluation seed (default 0)
  --threads N         torch threads (default 1)
  --out FILE.json     results JSON (default: none)
  --quiet             no per-episode progress
)";

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  namespace sim = msspr::sim;
  msspr::agent::AntExpertEvalOptions o;
  sim::EnvId env_id = sim::EnvId::kAntMazeMedium;
  std::string expert_path, out;
  bool quiet = false;
  try {
    msspr::cli::CliArgs args(
        argc, argv, {"help", "quiet"},
        {"expert", "env", "tasks", "episodes", "max-steps", "seed", "threads", "out"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw msspr::cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    expert_path = args.Get("expert", sim::DefaultAntExpert());
    env_id = sim::ParseEnvId(
        args.GetChoice("env", sim::EnvIdName(env_id), sim::EnvIdNames(sim::AntMazeEnvIds())));
    o.maze = sim::AntMazeName(env_id);
    o.tasks.clear();
    for (long t : args.GetIntList("tasks", "1,2,3,4,5", 1, 5))
      o.tasks.push_back(static_cast<int>(t));
    o.episodes = static_cast<int>(args.GetInt("episodes", 50, 1, 1000000));
    o.max_steps = static_cast<int>(args.GetInt("max-steps", 1000, 1, 100000000));
    o.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    torch::set_num_threads(static_cast<int>(args.GetInt("threads", 1, 1, 4096)));
    out = args.Get("out", "");
    quiet = args.Has("quiet");
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_ant_expert: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    msspr::core::SacPolicy policy(expert_path);
    std::cerr << "msspr_eval_ant_expert: " << expert_path << ", " << o.tasks.size() << " tasks x "
              << o.episodes << " episodes on " << sim::EnvIdName(env_id) << " (noise-free) ...\n";
    if (!quiet) {
      o.on_episode = [&](int task, int e, bool success, int steps) {
        std::fprintf(stderr, "[msspr_eval_ant_expert] task %d episode %d/%d: %s in %d steps\n",
                     task, e + 1, o.episodes, success ? "success" : "failure", steps);
      };
    }
    const auto r = msspr::agent::EvaluateAntExpert(policy, o);
    const sim::MazeMap map = sim::MazeMap::FromName(o.maze);
    const std::string agent = expert_path.substr(expert_path.find_last_of('/') + 1);
    const sim::EvalReport report = msspr::agent::MakeTaskReport(r, sim::EnvLabel(env_id), agent,
                                                                o.episodes, o.max_steps, o.seed);
    std::cout << sim::EvalReportTable(map, report);
    std::ostringstream speed;
    speed << std::fixed << std::setprecision(3);
    for (size_t i = 0; i < r.tasks.size(); ++i)
      speed << (i ? ", " : "") << "task " << r.tasks[i] << " " << r.speed[i];
    std::cout << "mean success " << std::setprecision(3) << std::fixed << r.mean_success
              << ", mean speed " << r.mean_speed << " m/s (" << speed.str() << ")\n";
    if (!out.empty()) {
      std::string json = sim::EvalReportJson(map, report);
      std::string escaped;
      for (char c : expert_path) {
        if (c == '"' || c == '\\') escaped.push_back('\\');
        escaped.push_back(c);
      }
      std::ostringstream extra;
      extra << std::fixed << std::setprecision(4) << ",\n  \"expert\": \"" << escaped
            << "\",\n  \"noise\": 0,\n  \"mean_speed_mps\": " << r.mean_speed
            << ",\n  \"speed_mps\": [";
      for (size_t i = 0; i < r.speed.size(); ++i) extra << (i ? ", " : "") << r.speed[i];
      extra << "],\n  \"steps\": " << r.steps;
      json.insert(json.rfind("\n}"), extra.str());
      sim::WriteTextFile(out, json);
    }
    std::fprintf(stderr, "msspr_eval_ant_expert: %lld steps in %.1f s (%.0f steps/s)\n",
                 static_cast<long long>(r.steps), r.seconds, r.steps / std::max(r.seconds, 1e-9));
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_ant_expert: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
