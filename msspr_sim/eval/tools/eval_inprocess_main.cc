// msspr_eval_inprocess: OGBench's evaluation protocol for a checkpoint, in
// process (no ROS master, no sim node): the episodes of msspr_eval (same seeds)
// run side by side, one policy call per control step. The results
// JSON has msspr_eval's format; msspr_train's evaluations run the same code.
#include <torch/torch.h>

#include <algorithm>
#include <iostream>
#include <set>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_core/policy.h"
#include "msspr_core/process_env.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_eval/maze_evaluator.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/maze_plot.h"
#include "msspr_sim/package_files.h"

namespace {

constexpr const char* kUsage = R"(usage: msspr_eval_inprocess --policy POLICY.pt [options]
Evaluates a checkpoint by OGBench's protocol in process (the episodes of msspr_eval --seed S).
  --policy FILE       a policy export (policy.pt) or a training checkpoint (required)
  --env ENV           pointmaze | cube-single | antmaze-medium | antmaze-large (default pointmaze)
  --maze NAME         arena, medium, large or giant (default medium; pointmaze only;
                      --env pointmaze-NAME says the same)
  --tasks LIST        task ids (default 1,2,3,4,5)
  --tasks-file YAML   custom tasks instead (msspr_eval --tasks-file format; pointmaze only)
  --episodes N        episodes per task (default 50)
  --max-steps N       step limit (default 1000; cube-single 200)
  --seed S            evaluation seed (default 0)
  --threads N         torch threads (default: torch's choice; the results do not depend on it)
  --device DEV        where the policy runs: cpu, cuda, cuda:1 (default cpu)
  --agent NAME        label in the results (default: the policy's file name)
  --out FILE.json     results JSON (default: none)
  --plot FILE.png     trajectories on the maze (default: none; pointmaze only)
  --urdf FILE         cube-single: the arm (default: the package's msspr_sim/urdf/ur5e_2f85.urdf)
Prints the per-task table. The point mazes and cube-single take state or pixels
policies (pixels: the sim's 64x64 camera images and the goal's image); the ant
mazes, state policies.
)";

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithPassiveOpenMpWait(argv);
  namespace sim = msspr::sim;
  msspr::agent::MazeEvalOptions eo;
  msspr::agent::CubeEvalOptions co;
  msspr::agent::AntEvalOptions ao;
  bool cube = false, ant = false;
  std::string policy_path, out, plot, agent, device;
  try {
    msspr::cli::CliArgs args(
        argc, argv, {"help"},
        {"policy", "env", "maze", "tasks", "tasks-file", "episodes", "max-steps", "seed", "threads",
         "device", "agent", "out", "plot", "urdf"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw msspr::cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    policy_path = args.Get("policy", "");
    if (policy_path.empty()) throw msspr::cli::CliError("--policy is required");
    using sim::EnvId;
    std::string maze;  // --env pointmaze-NAME or --maze NAME
    const EnvId env = sim::ParseEnvFlag(args.Get("env", sim::EnvIdName(EnvId::kPointMaze)),
                                        args.Get("maze", ""), sim::AllEnvIds(), &maze);
    cube = env == EnvId::kCubeSingle;
    ant = sim::IsAntMaze(env);
    if (ant) {
      for (const char* f : {"maze", "tasks-file", "plot", "urdf"})
        if (args.Has(f))
          throw msspr::cli::CliError(std::string("--") + f + " does not apply to --env " +
                                     sim::EnvIdName(env));
      ao.maze = sim::AntMazeName(env);
      ao.tasks.clear();
      for (long t : args.GetIntList("tasks", "1,2,3,4,5", 1, 5))
        ao.tasks.push_back(static_cast<int>(t));
      ao.episodes = static_cast<int>(args.GetInt("episodes", 50, 1, 1000000));
      ao.max_steps = static_cast<int>(args.GetInt("max-steps", 1000, 1, 100000000));
      ao.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    } else if (cube) {
      for (const char* f : {"maze", "tasks-file", "plot"})
        if (args.Has(f))
          throw msspr::cli::CliError(std::string("--") + f +
                                     " does not apply to --env cube-single");
      co.urdf_path = args.Get("urdf", "");
      co.tasks.clear();
      for (long t : args.GetIntList("tasks", "1,2,3,4,5", 1, 5))
        co.tasks.push_back(static_cast<int>(t));
      co.episodes = static_cast<int>(args.GetInt("episodes", 50, 1, 1000000));
      co.max_steps = static_cast<int>(args.GetInt("max-steps", 200, 1, 100000000));
      co.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    } else {
      if (args.Has("urdf")) throw msspr::cli::CliError("--urdf applies to --env cube-single only");
      eo.maze = sim::PointMazeOrDefault(maze);
      const auto map = sim::MazeMap::FromName(eo.maze);
      if (args.Has("tasks-file") && args.Has("tasks"))
        throw msspr::cli::CliError("give --tasks or --tasks-file, not both");
      if (args.Has("tasks-file")) {
        try {
          eo.custom_tasks = sim::LoadCustomTasks(args.Get("tasks-file", ""), &map);
        } catch (const std::runtime_error& e) {
          throw msspr::cli::CliError("--tasks-file: " + std::string(e.what()));
        }
      } else {
        eo.tasks.clear();
        for (long t :
             args.GetIntList("tasks", "1,2,3,4,5", 1, static_cast<long>(map.Tasks().size())))
          eo.tasks.push_back(static_cast<int>(t));
      }
      eo.episodes = static_cast<int>(args.GetInt("episodes", 50, 1, 1000000));
      eo.max_steps = static_cast<int>(args.GetInt("max-steps", 1000, 1, 100000000));
      eo.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    }
    const int threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
    if (threads > 0) torch::set_num_threads(threads);
    device = args.Get("device", "cpu");
    try {
      (void)torch::Device(device);
    } catch (const std::exception&) {
      throw msspr::cli::CliError("--device: '" + device + "' is not a device (cpu, cuda, cuda:N)");
    }
    out = args.Get("out", "");
    plot = args.Get("plot", "");
    eo.keep_paths = !plot.empty();
    agent = args.Get("agent", policy_path.substr(policy_path.find_last_of('/') + 1));
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_inprocess: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    auto policy = msspr::core::Policy::Load(policy_path, torch::Device(device));
    if (ant) {
      std::cerr << "msspr_eval_inprocess: " << policy_path << ", " << ao.tasks.size() << " tasks x "
                << ao.episodes << " episodes on " << sim::EnvLabel(sim::AntMazeEnvId(ao.maze))
                << " ...\n";
      const auto result = msspr::agent::EvaluateOnAntMaze(policy, ao);
      const sim::EvalReport report = msspr::agent::MakeAntEvalReport(result, ao, agent);
      std::cout << sim::EvalReportTable(sim::MazeMap::FromName(ao.maze), report);
      if (!out.empty()) msspr::agent::WriteAntResultsJson(result, ao, agent, out);
      std::cerr << "msspr_eval_inprocess: mean success " << report.mean_success << " in "
                << result.seconds << " s\n";
      return 0;
    }
    if (cube) {
      if (co.urdf_path.empty()) co.urdf_path = sim::DefaultArmUrdf();
      std::cerr << "msspr_eval_inprocess: " << policy_path << ", " << co.tasks.size() << " tasks x "
                << co.episodes << " episodes on cube-single ("
                << (policy.pixels() ? "pixels" : "states") << "; arm " << co.urdf_path << ") ...\n";
      const auto result = msspr::agent::EvaluateOnCube(policy, co);
      const sim::EvalReport report = msspr::agent::MakeCubeEvalReport(result, co, agent);
      std::cout << sim::EvalReportTable(report);
      if (!out.empty()) msspr::agent::WriteCubeResultsJson(result, co, agent, out);
      std::cerr << "msspr_eval_inprocess: mean success " << report.mean_success << " in "
                << result.seconds << " s\n";
      return 0;
    }
    std::cerr << "msspr_eval_inprocess: " << policy_path << " ("
              << (policy.pixels() ? "pixels" : "states") << "), "
              << (eo.custom_tasks.empty() ? eo.tasks.size() : eo.custom_tasks.size()) << " tasks x "
              << eo.episodes << " episodes on " << eo.maze << " ...\n";
    const auto result = msspr::agent::EvaluateOnMaze(policy, eo);
    const auto map = sim::MazeMap::FromName(eo.maze);
    const sim::EvalReport report = msspr::agent::MakeEvalReport(result, eo, agent);
    std::cout << sim::EvalReportTable(map, report);
    if (!out.empty()) sim::WriteTextFile(out, sim::EvalReportJson(map, report));
    if (!plot.empty()) {  // up to 5 episodes per task
      std::vector<std::vector<Eigen::Vector2d>> paths;
      std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> sg;
      std::vector<bool> ok;
      for (size_t t = 0; t < result.paths.size(); ++t)
        for (size_t e = 0; e < result.paths[t].size() && e < 5; ++e) {
          paths.push_back(result.paths[t][e]);
          sg.push_back(result.start_goal[t][e]);
          ok.push_back(result.episode_success[t][e]);
        }
      sim::SaveTrajectoryPlot(map, paths, sg, ok, plot);
    }
    std::cerr << "msspr_eval_inprocess: mean success " << report.mean_success << " in "
              << result.seconds << " s\n";
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_inprocess: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
