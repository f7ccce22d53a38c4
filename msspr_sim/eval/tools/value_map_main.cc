// msspr_value_map: the value-error map of the paper's App. E for a trained
// checkpoint. For one goal, starts on a grid over the maze's free cells; from
// each, Monte Carlo rollouts of the frozen policy give the true discounted
// return and the success rate; the critic's estimate V(s, g) = min_k Q_k(s,
// pi(s, g), g) is compared with it. Writes three heatmaps (predicted, true,
// error) and a JSON with the mean absolute error and the correlation.
// --env cube-single: the critic's value of a state whose cube rests at a
// task's goal, against goals whose cube is moved 0-10 cm away (whether it
// tells a placement within the 4 cm of success from a miss).
#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>
#include <string>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/policy.h"
#include "msspr_core/process_env.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_eval/maze_evaluator.h"
#include "msspr_sim/eval_protocol.h"
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
  --env cube-single  instead: the critic's value V(s, g) of a state whose cube rests at a task's
                     goal, for goals whose cube is moved SHIFT cm away in the table's plane
                     (success needs 4 cm); prints a table, writes DIR/value_goal_shifts.json
  --shifts LIST      cube-single: the shifts in cm (default 0,1,2,3,4,5,6,8,10)
  --pairs N          cube-single: state and goal pairs per task (default 20)
  --directions N     cube-single: directions of each shift (default 8)
Example: rosrun msspr msspr_value_map --policy $(rospack find msspr)/msspr_policy_node/checkpoints/pointmaze-medium-state.pt --out value_map
         rosrun msspr msspr_value_map --env cube-single --policy $(rospack find msspr)/msspr_policy_node/checkpoints/cube-single-state.pt
)";

// The point maze's flags.
void ParseMazeFlags(const msspr::cli::CliArgs& args, msspr::agent::ValueMapOptions* vo_out) {
  using msspr::cli::CliError;
  msspr::agent::ValueMapOptions& vo = *vo_out;
  const auto names = msspr::sim::MazeMap::Names();
  vo.maze = args.GetChoice("maze", "medium", std::set<std::string>(names.begin(), names.end()));
  const auto map = msspr::sim::MazeMap::FromName(vo.maze);
  if (args.Has("goal") && args.Has("goal-task"))
    throw CliError("give --goal or --goal-task, not both");
  if (args.Has("goal")) {
    const std::string g = args.Get("goal", "");
    const auto comma = g.find(',');
    if (comma == std::string::npos) throw CliError("--goal expects X,Y in metres, got '" + g + "'");
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
  vo.start_noise =
      args.GetDouble("start-noise", 0.1, 0.0, msspr::sim::kCellSize / 2 - msspr::sim::kAgentRadius);
  vo.max_steps = static_cast<int>(args.GetInt("max-steps", 1000, 1, 100000000));
  vo.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
}

// --env cube-single: the probe, its table and its JSON.
int RunCubeGoalShifts(const std::string& policy_path, const msspr::agent::CubeGoalShiftOptions& co,
                      const std::string& agent, const std::string& out) {
  auto policy = msspr::core::Policy::Load(policy_path);
  std::cerr << "msspr_value_map: " << policy_path << " (" << policy.agent_name() << "), "
            << co.pairs_per_task << " state and goal pairs per task x " << co.directions
            << " directions per shift ...\n";
  const auto r = msspr::agent::ProbeCubeGoalShifts(policy, co);
  std::printf(
      "%s: V(s, g) of a state with the cube at the goal, the goal's cube moved SHIFT cm (%d "
      "values a shift; gamma %.4g; steps: the steps to go V stands for; steer: the cosine "
      "between the action's horizontal move and the shift)\n",
      agent.c_str(), r.samples, r.gamma);
  std::printf("%10s | %-20s | %-20s | %-24s\n", "", "arm as the goal's", "another arm",
              "carrying it 5 cm above");
  std::printf("%10s | %9s %10s | %9s %10s | %9s %14s\n", "shift (cm)", "V", "steps", "V", "steps",
              "V", "steer (cos)");
  for (size_t i = 0; i < r.shifts_cm.size(); ++i)
    std::printf("%10.1f | %9.2f %10.1f | %9.2f %10.1f | %9.2f %14.2f\n", r.shifts_cm[i],
                r.same_arm.mean[i], r.same_arm.steps[i], r.other_arm.mean[i], r.other_arm.steps[i],
                r.carrying.mean[i], r.carrying.steer[i]);
  const std::string path = out + "/value_goal_shifts.json";
  std::ostringstream f;  // the JSON, written as value_map.json is (sim::WriteTextFile)
  auto list = [&f](const std::vector<double>& xs) {
    f << "[";
    for (size_t i = 0; i < xs.size(); ++i)
      f << (i ? ", " : "") << (std::isfinite(xs[i]) ? std::to_string(xs[i]) : "null");
    f << "]";
  };
  f << "{\"agent\": \"" << agent << "\", \"policy\": \"" << policy_path
    << "\", \"env\": \"cube-single\", \"samples_per_shift\": " << r.samples
    << ", \"gamma\": " << r.gamma << ", \"shifts_cm\": ";
  list(r.shifts_cm);
  for (const auto& [name, v] :
       {std::pair{"same_arm", &r.same_arm}, std::pair{"other_arm", &r.other_arm},
        std::pair{"carrying", &r.carrying}}) {
    f << ", \"" << name << "\": {\"mean_value\": ";
    list(v->mean);
    f << ", \"sd_value\": ";
    list(v->sd);
    f << ", \"steps\": ";
    list(v->steps);
    if (!v->steer.empty()) {
      f << ", \"steer\": ";
      list(v->steer);
    }
    f << "}";
  }
  f << "}\n";
  msspr::sim::WriteTextFile(path, f.str());
  std::cerr << "msspr_value_map: wrote " << path << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  using msspr::cli::CliError;
  msspr::agent::ValueMapOptions vo;
  msspr::agent::CubeGoalShiftOptions co;
  std::string policy_path, out, agent, env;
  try {
    msspr::cli::CliArgs args(
        argc, argv, {"help"},
        {"policy", "maze", "goal-task", "goal", "per-cell", "rollouts", "start-noise", "max-steps",
         "seed", "threads", "agent", "out", "env", "shifts", "pairs", "directions"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw CliError("unexpected argument '" + args.positional()[0] + "'");
    policy_path = args.Get("policy", "");
    if (policy_path.empty()) throw CliError("--policy is required");
    env = args.GetChoice("env", "pointmaze", {"pointmaze", "cube-single"});
    const bool cube = env == "cube-single";
    for (const char* flag :
         {"maze", "goal-task", "goal", "per-cell", "rollouts", "start-noise", "max-steps"})
      if (cube && args.Has(flag))
        throw CliError(std::string("--") + flag + " is for the point maze, not --env cube-single");
    for (const char* flag : {"shifts", "pairs", "directions"})
      if (!cube && args.Has(flag))
        throw CliError(std::string("--") + flag + " is for --env cube-single");
    if (cube) {
      if (args.Has("shifts")) {
        co.shifts_cm.clear();
        std::stringstream list(args.Get("shifts", ""));
        for (std::string item; std::getline(list, item, ',');)
          co.shifts_cm.push_back(msspr::cli::ParseDouble("shifts", item, 0.0, 100.0));
        if (co.shifts_cm.empty()) throw CliError("--shifts expects cm values, e.g. 0,2,4,6");
      }
      co.pairs_per_task = static_cast<int>(args.GetInt("pairs", 20, 1, 10000));
      co.directions = static_cast<int>(args.GetInt("directions", 8, 1, 360));
      co.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    } else {
      ParseMazeFlags(args, &vo);
    }
    const int threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
    if (threads > 0) torch::set_num_threads(threads);
    out = args.Get("out", "value_map");
    agent = args.Get("agent", "");
    if (agent.empty()) agent = policy_path.substr(policy_path.find_last_of('/') + 1);
  } catch (const std::exception& e) {
    std::cerr << "msspr_value_map: " << e.what() << "\n" << kUsage;
    return 2;
  }
  if (env == "cube-single") {
    try {
      return RunCubeGoalShifts(policy_path, co, agent, out);
    } catch (const std::exception& e) {
      std::cerr << "msspr_value_map: " << e.what() << "\n";
      return 1;
    }
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
