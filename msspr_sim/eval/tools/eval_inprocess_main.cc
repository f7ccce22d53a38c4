// msspr_eval_inprocess: OGBench's evaluation protocol for a checkpoint, in
// process (no ROS master, no sim node): the episodes of msspr_eval (same seeds)
// run side by side, one policy call per control step. The results
// JSON has msspr_eval's format; msspr_train's evaluations run the same code.
#include <torch/torch.h>

#include <algorithm>
#include <initializer_list>
#include <iostream>
#include <set>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_core/policy.h"
#include "msspr_core/process_env.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/arm_task_evaluator.h"
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
  --env ENV           pointmaze | cube-single | cube-double | scene | antmaze-medium |
                      antmaze-large | puzzle-3x3 | puzzle-4x4 (default pointmaze)
  --maze NAME         arena, medium, large or giant (default medium; pointmaze only;
                      --env pointmaze-NAME says the same)
  --tasks LIST        task ids (default 1,2,3,4,5)
  --tasks-file YAML   custom tasks instead (msspr_eval --tasks-file format; pointmaze only)
  --episodes N        episodes per task (default 50)
  --max-steps N       step limit (default 1000; cube-single 200, cube-double and puzzles 500,
                      the scene 750)
  --seed S            evaluation seed (default 0)
  --threads N         torch threads (default: torch's choice; the results do not depend on it)
  --device DEV        where the policy runs: cpu, cuda, cuda:1 (default cpu)
  --agent NAME        label in the results (default: the policy's file name)
  --out FILE.json     results JSON (default: none)
  --plot FILE.png     trajectories on the maze (default: none; pointmaze only)
  --urdf FILE         cube-single, cube-double, scene, puzzles: the arm (default: the package's
                      msspr_sim/urdf/ur5e_2f85.urdf)
Prints the per-task table. The point mazes and cube-single take state or pixels
policies (pixels: the sim's 64x64 camera images and the goal's image); the ant
mazes, cube-double, the scene and the puzzles, state policies.
)";

// The shared episode flags (sim::ReadEpisodeFlags) into an env's options; the tasks too
// unless the caller reads them itself.
template <class Options>
void ReadEpisodeFlags(const msspr::cli::CliArgs& args, int max_steps, long tasks, Options* o,
                      bool read_tasks = true) {
  const msspr::sim::EpisodeFlags f =
      msspr::sim::ReadEpisodeFlags(args, max_steps, tasks, read_tasks);
  if (read_tasks) o->tasks = f.tasks;
  o->episodes = f.episodes;
  o->max_steps = f.max_steps;
  o->seed = f.seed;
}

void RefuseFlags(const msspr::cli::CliArgs& args, std::initializer_list<const char*> flags,
                 const std::string& env) {
  for (const char* f : flags)
    if (args.Has(f))
      throw msspr::cli::CliError(std::string("--") + f + " does not apply to --env " + env);
}

// What the command line asks for; throws CliError (and CliArgs' errors).
struct Request {
  msspr::sim::EnvId env = msspr::sim::EnvId::kPointMaze;
  msspr::agent::MazeEvalOptions maze;
  msspr::agent::CubeEvalOptions cube;
  msspr::agent::AntEvalOptions ant;
  msspr::agent::PuzzleEvalOptions puzzle;
  msspr::agent::ArmTaskEvalOptions arm_task;  // cube-double, scene
  std::string policy_path, out, plot, agent, device;
  bool is_cube() const { return env == msspr::sim::EnvId::kCubeSingle; }
  bool is_ant() const { return msspr::sim::IsAntMaze(env); }
  bool is_puzzle() const { return msspr::sim::IsPuzzle(env); }
  bool is_cube_double() const { return env == msspr::sim::EnvId::kCubeDouble; }
  bool is_scene() const { return env == msspr::sim::EnvId::kScene; }
};

Request ParseRequest(const msspr::cli::CliArgs& args) {
  namespace sim = msspr::sim;
  Request q;
  if (!args.positional().empty())
    throw msspr::cli::CliError("unexpected argument '" + args.positional()[0] + "'");
  q.policy_path = args.Get("policy", "");
  if (q.policy_path.empty()) throw msspr::cli::CliError("--policy is required");
  std::string maze;  // --env pointmaze-NAME or --maze NAME
  q.env = sim::ParseEnvFlag(args.Get("env", sim::EnvIdName(sim::EnvId::kPointMaze)),
                            args.Get("maze", ""), sim::AllEnvIds(), &maze);
  if (q.is_ant()) {
    RefuseFlags(args, {"maze", "tasks-file", "plot", "urdf"}, sim::EnvIdName(q.env));
    q.ant.maze = sim::AntMazeName(q.env);
    ReadEpisodeFlags(args, sim::EvalEpisodeCap(q.env), 5, &q.ant);
  } else if (q.is_puzzle()) {
    RefuseFlags(args, {"maze", "tasks-file", "plot"}, sim::EnvIdName(q.env));
    q.puzzle.side = sim::PuzzleSide(q.env);
    q.puzzle.urdf_path = args.Get("urdf", "");
    ReadEpisodeFlags(args, sim::EvalEpisodeCap(q.env), 5, &q.puzzle);
  } else if (q.is_cube_double() || q.is_scene()) {
    RefuseFlags(args, {"maze", "tasks-file", "plot"}, sim::EnvIdName(q.env));
    q.arm_task.urdf_path = args.Get("urdf", "");
    ReadEpisodeFlags(args, sim::EvalEpisodeCap(q.env), 5, &q.arm_task);
  } else if (q.is_cube()) {
    RefuseFlags(args, {"maze", "tasks-file", "plot"}, "cube-single");
    q.cube.urdf_path = args.Get("urdf", "");
    ReadEpisodeFlags(args, sim::EvalEpisodeCap(q.env), 5, &q.cube);
  } else {
    if (args.Has("urdf"))
      throw msspr::cli::CliError(
          "--urdf applies to the arm's envs only (cube-single, cube-double, scene, puzzles)");
    q.maze.maze = sim::PointMazeOrDefault(maze);
    const auto map = sim::MazeMap::FromName(q.maze.maze);
    if (args.Has("tasks-file") && args.Has("tasks"))
      throw msspr::cli::CliError("give --tasks or --tasks-file, not both");
    if (args.Has("tasks-file")) {
      try {
        q.maze.custom_tasks = sim::LoadCustomTasks(args.Get("tasks-file", ""), &map);
      } catch (const std::runtime_error& e) {
        throw msspr::cli::CliError("--tasks-file: " + std::string(e.what()));
      }
    }
    ReadEpisodeFlags(args, sim::EvalEpisodeCap(q.env), static_cast<long>(map.Tasks().size()),
                     &q.maze, !args.Has("tasks-file"));
  }
  const int threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
  if (threads > 0) torch::set_num_threads(threads);
  q.device = args.Get("device", "cpu");
  try {
    (void)torch::Device(q.device);
  } catch (const std::exception&) {
    throw msspr::cli::CliError("--device: '" + q.device + "' is not a device (cpu, cuda, cuda:N)");
  }
  q.out = args.Get("out", "");
  q.plot = args.Get("plot", "");
  q.maze.keep_paths = !q.plot.empty();
  q.agent = args.Get("agent", q.policy_path.substr(q.policy_path.find_last_of('/') + 1));
  return q;
}

void PrintMean(double mean_success, double seconds) {
  std::cerr << "msspr_eval_inprocess: mean success " << mean_success << " in " << seconds << " s\n";
}

void RunAnt(msspr::core::Policy& policy, const Request& q) {
  namespace sim = msspr::sim;
  std::cerr << "msspr_eval_inprocess: " << q.policy_path << ", " << q.ant.tasks.size()
            << " tasks x " << q.ant.episodes << " episodes on "
            << sim::EnvLabel(sim::AntMazeEnvId(q.ant.maze)) << " ...\n";
  const auto result = msspr::agent::EvaluateOnAntMaze(policy, q.ant);
  const sim::EvalReport report = msspr::agent::MakeAntEvalReport(result, q.ant, q.agent);
  std::cout << sim::EvalReportTable(sim::MazeMap::FromName(q.ant.maze), report);
  if (!q.out.empty()) msspr::agent::WriteAntResultsJson(result, q.ant, q.agent, q.out);
  PrintMean(report.mean_success, result.seconds);
}

void RunCube(msspr::core::Policy& policy, Request q) {
  namespace sim = msspr::sim;
  if (q.cube.urdf_path.empty()) q.cube.urdf_path = sim::DefaultArmUrdf();
  std::cerr << "msspr_eval_inprocess: " << q.policy_path << ", " << q.cube.tasks.size()
            << " tasks x " << q.cube.episodes << " episodes on cube-single ("
            << (policy.pixels() ? "pixels" : "states") << "; arm " << q.cube.urdf_path << ") ...\n";
  const auto result = msspr::agent::EvaluateOnCube(policy, q.cube);
  const sim::EvalReport report = msspr::agent::MakeCubeEvalReport(result, q.cube, q.agent);
  std::cout << sim::EvalReportTable(report);
  if (!q.out.empty()) msspr::agent::WriteCubeResultsJson(result, q.cube, q.agent, q.out);
  std::cout << "  "
            << sim::DescribeCubeFailures(sim::CountCubeFailures(msspr::agent::CubeOutcomes(result)))
            << "\n";
  PrintMean(report.mean_success, result.seconds);
}

// A state-only arm task (a puzzle, cube-double): evaluate, print the table, write the JSON.
template <class Options, class Evaluate, class MakeReport, class Write>
void RunArmTask(msspr::core::Policy& policy, const Request& q, Options options, Evaluate evaluate,
                MakeReport make_report, Write write) {
  namespace sim = msspr::sim;
  if (options.urdf_path.empty()) options.urdf_path = sim::DefaultArmUrdf();
  std::cerr << "msspr_eval_inprocess: " << q.policy_path << ", " << options.tasks.size()
            << " tasks x " << options.episodes << " episodes on " << sim::EnvIdName(q.env)
            << " (states; arm " << options.urdf_path << ") ...\n";
  const auto result = evaluate(policy, options);
  const sim::EvalReport report = make_report(result, options, q.agent);
  std::cout << sim::EvalReportTable(report);
  if (!q.out.empty()) write(result, options, q.agent, q.out);
  PrintMean(report.mean_success, result.seconds);
}

void RunMaze(msspr::core::Policy& policy, const Request& q) {
  namespace sim = msspr::sim;
  const auto& eo = q.maze;
  std::cerr << "msspr_eval_inprocess: " << q.policy_path << " ("
            << (policy.pixels() ? "pixels" : "states") << "), "
            << (eo.custom_tasks.empty() ? eo.tasks.size() : eo.custom_tasks.size()) << " tasks x "
            << eo.episodes << " episodes on " << eo.maze << " ...\n";
  const auto result = msspr::agent::EvaluateOnMaze(policy, eo);
  const auto map = sim::MazeMap::FromName(eo.maze);
  const sim::EvalReport report = msspr::agent::MakeEvalReport(result, eo, q.agent);
  std::cout << sim::EvalReportTable(map, report);
  if (!q.out.empty()) sim::WriteTextFile(q.out, sim::EvalReportJson(map, report));
  if (!q.plot.empty()) {  // up to 5 episodes per task
    std::vector<std::vector<Eigen::Vector2d>> paths;
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> sg;
    std::vector<bool> ok;
    for (size_t t = 0; t < result.paths.size(); ++t)
      for (size_t e = 0; e < result.paths[t].size() && e < 5; ++e) {
        paths.push_back(result.paths[t][e]);
        sg.push_back(result.start_goal[t][e]);
        ok.push_back(result.episode_success[t][e]);
      }
    sim::SaveTrajectoryPlot(map, paths, sg, ok, q.plot);
  }
  PrintMean(report.mean_success, result.seconds);
}

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  Request q;
  try {
    msspr::cli::CliArgs args(
        argc, argv, {"help"},
        {"policy", "env", "maze", "tasks", "tasks-file", "episodes", "max-steps", "seed", "threads",
         "device", "agent", "out", "plot", "urdf"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    q = ParseRequest(args);
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_inprocess: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    auto policy = msspr::core::Policy::Load(q.policy_path, torch::Device(q.device));
    if (q.is_ant())
      RunAnt(policy, q);
    else if (q.is_cube())
      RunCube(policy, q);
    else if (q.is_puzzle())
      RunArmTask(policy, q, q.puzzle, msspr::agent::EvaluateOnPuzzle,
                 msspr::agent::MakePuzzleEvalReport, msspr::agent::WritePuzzleResultsJson);
    else if (q.is_cube_double())
      RunArmTask(policy, q, q.arm_task, msspr::agent::EvaluateOnCubeDouble,
                 msspr::agent::MakeCubeDoubleEvalReport, msspr::agent::WriteCubeDoubleResultsJson);
    else if (q.is_scene())
      RunArmTask(policy, q, q.arm_task, msspr::agent::EvaluateOnScene,
                 msspr::agent::MakeSceneEvalReport, msspr::agent::WriteSceneResultsJson);
    else
      RunMaze(policy, q);
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval_inprocess: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
