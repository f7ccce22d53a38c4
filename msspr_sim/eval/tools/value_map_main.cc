// msspr_value_map: the value-error map of the paper's App. E for a trained
// checkpoint. For one goal, starts on a grid over the maze's free cells; from
// each, Monte Carlo rollouts of the frozen policy give the true discounted
// return and the success rate; the critic's estimate V(s, g) = min_k Q_k(s,
// pi(s, g), g) is compared with it. Writes three heatmaps (predicted, true,
// error) and a JSON with the mean absolute error and the correlation.
#include <torch/torch.h>

#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>
#include <string>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/policy.h"
#include "msspr_core/process_env.h"
#include "msspr_eval/maze_evaluator.h"
#include "msspr_sim/maze_map.h"

namespace {

constexpr const char* kUsage = R"(usage: msspr_value_map --policy POLICY.pt [options]
The value-error map of the paper's App. E: critic estimate against Monte Carlo returns of the
frozen policy, for one goal, over a grid of starts covering the free cells.
  --policy FILE      a policy export (policy.pt) or a training checkpoint (required)
  --maze NAME        arena, medium, large or giant (default medium)
  --goal-task N      the goal: the centre of task N's goal cell (default 1)
  --goal X,Y         the goal in metres (instead of --goal-task)
  --per-cell N       starts per cell per axis: N*N per free cell (default 3)
  --rollouts N       rollouts per start (default 10)
  --start-noise M    uniform noise per axis on each rollout's start, metres (default 0.1)
  --max-steps N      step limit per rollout (default 1000)
  --seed S           seed of the start noise (default 0)
  --threads N        torch threads (default: torch's choice)
  --agent NAME       label in the pictures and the JSON (default: the policy's file name)
  --out DIR          output directory (default value_map): value_predicted.png, value_true.png,
                     value_error.png (predicted - true), value_map.json
Example: rosrun msspr msspr_value_map --policy $(rospack find msspr)/msspr_policy_node/checkpoints/pointmaze-medium-state.pt --out value_map
)";

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  using msspr::cli::CliError;
  msspr::agent::ValueMapOptions vo;
  std::string policy_path, out, agent;
  try {
    msspr::cli::CliArgs args(argc, argv, {"help"},
                             {"policy", "maze", "goal-task", "goal", "per-cell", "rollouts",
                              "start-noise", "max-steps", "seed", "threads", "agent", "out"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw CliError("unexpected argument '" + args.positional()[0] + "'");
    policy_path = args.Get("policy", "");
    if (policy_path.empty()) throw CliError("--policy is required");
    const auto names = msspr::sim::MazeMap::Names();
    vo.maze = args.GetChoice("maze", "medium", std::set<std::string>(names.begin(), names.end()));
    const auto map = msspr::sim::MazeMap::FromName(vo.maze);
    if (args.Has("goal") && args.Has("goal-task"))
      throw CliError("give --goal or --goal-task, not both");
    if (args.Has("goal")) {
      const std::string g = args.Get("goal", "");
      const auto comma = g.find(',');
      if (comma == std::string::npos)
        throw CliError("--goal expects X,Y in metres, got '" + g + "'");
      vo.goal = {msspr::cli::ParseDouble("goal", g.substr(0, comma)),
                 msspr::cli::ParseDouble("goal", g.substr(comma + 1))};
      if (map.IsWall(map.XYToCell(vo.goal)))
        throw CliError("--goal " + g + " is inside a wall of maze " + vo.maze);
    } else {
      const int task =
          static_cast<int>(args.GetInt("goal-task", 1, 1, static_cast<long>(map.Tasks().size())));
      vo.goal = map.CellCenter(map.Tasks()[static_cast<size_t>(task - 1)].goal);
    }
    vo.per_cell = static_cast<int>(args.GetInt("per-cell", 3, 1, 20));
    vo.rollouts = static_cast<int>(args.GetInt("rollouts", 10, 1, 10000));
    vo.start_noise = args.GetDouble("start-noise", 0.1, 0.0,
                                    msspr::sim::kCellSize / 2 - msspr::sim::kAgentRadius);
    vo.max_steps = static_cast<int>(args.GetInt("max-steps", 1000, 1, 100000000));
    vo.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    const int threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
    if (threads > 0) torch::set_num_threads(threads);
    out = args.Get("out", "value_map");
    agent = args.Get("agent", "");
    if (agent.empty()) {
      agent = policy_path.substr(policy_path.find_last_of('/') + 1);
    }
  } catch (const std::exception& e) {
    std::cerr << "msspr_value_map: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    torch::manual_seed(static_cast<uint64_t>(vo.seed));
    auto policy = msspr::core::Policy::Load(policy_path);
    std::cerr << "msspr_value_map: " << policy_path << " ("
              << (policy.pixels() ? "pixels" : "states") << "), goal (" << vo.goal.x() << ", "
              << vo.goal.y() << "), " << vo.per_cell * vo.per_cell << " starts per free cell x "
              << vo.rollouts << " rollouts ...\n";
    const auto result = msspr::agent::ComputeValueMap(policy, vo);
    msspr::agent::WriteValueMap(result, vo, agent, out);
    std::printf(
        "{\"points\": %zu, \"episodes\": %d, \"mean_abs_error\": %.4f, \"bias\": %.4f, "
        "\"correlation\": %.4f, \"mean_success\": %.4f, \"wall_time_s\": %.1f, \"out\": \"%s\"}\n",
        result.points.size(), result.episodes, result.mean_abs_error, result.bias,
        result.correlation, result.mean_success, result.seconds, out.c_str());
  } catch (const std::exception& e) {
    std::cerr << "msspr_value_map: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
