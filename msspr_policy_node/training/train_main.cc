// msspr_train (catkin build): the core's training command line, plus msspr
// dataset bags (--data a.bag,b.bag; the "val" split of the same bags validates
// unless --val is given) and success rates in the point maze or cube-single
// (the bags' env), evaluated in process every --eval-every steps by OGBench's
// protocol.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <vector>

#include "bag_dataset.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/process_env.h"
#include "msspr_core/train_cli.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/arm_task_evaluator.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_eval/maze_evaluator.h"
#include "msspr_robot_interface/robot_spec.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/learning_curve.h"
#include "msspr_sim/maze_map.h"

namespace {

using msspr::agent::BagLoadOptions;
using msspr::agent::BagLoadReport;

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string part;
  while (std::getline(ss, part, ','))
    if (!part.empty()) out.push_back(part);
  return out;
}

bool AllBags(const std::string& list) {
  const auto parts = SplitList(list);
  if (parts.empty()) return false;
  for (const auto& p : parts)
    if (!msspr::agent::IsBagPath(p)) return false;
  return true;
}

std::string g_env;  // env of the training bags, for the default evaluation maze
// --robot SPEC.yaml: the bags hold the robot's standard messages, read through this spec.
std::unique_ptr<msspr::ros_bridge::RobotSpec> g_robot;
// --ns NS: the namespace the spec's relative topics resolve under in the bags.
std::string g_ns;

// Reads --robot (before the core parses the rest) and joins "--data a.bag b.bag"
// into the core's "--data a.bag,b.bag". Returns the arguments to parse; throws on a bad spec.
std::vector<std::string> PrepareArgs(int argc, char** argv) {
  std::vector<std::string> out;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data") {
      std::string list;
      while (i + 1 < argc && argv[i + 1][0] != '-')
        list += (list.empty() ? "" : ",") + std::string(argv[++i]);
      out.push_back(a);
      if (!list.empty()) out.push_back(list);
      continue;
    }
    if (a == "--ns" && i + 1 < argc) g_ns = argv[i + 1];
    if (a == "--robot" && i + 1 < argc) {
      g_robot = std::make_unique<msspr::ros_bridge::RobotSpec>(
          msspr::ros_bridge::LoadRobotSpec(argv[i + 1]));
      // Every checkpoint and policy export of this run carries the spec.
      msspr::core::SetCheckpointMetadata(msspr::ros_bridge::kRobotSpecCheckpointKey, g_robot->text);
    }
    out.push_back(a);
  }
  return out;
}

// An evaluation's eval.csv rows: success_<kind><id> per task and mean_success<suffix>.
void AddSuccessRows(const msspr::agent::TaskSuccessResult& result, const std::string& kind,
                    const std::string& suffix, msspr::core::EvalResult* r) {
  for (size_t i = 0; i < result.tasks.size(); ++i)
    r->emplace_back("success_" + kind + std::to_string(result.tasks[i]), result.success[i]);
  r->emplace_back("mean_success" + suffix, result.mean_success);
}

// DIR/eval/step_<N><suffix>.json, the results JSON of the evaluation at step N.
std::string StepJsonPath(const std::string& out_dir, int64_t step, const std::string& suffix) {
  char name[64];
  std::snprintf(name, sizeof name, "/eval/step_%08lld", static_cast<long long>(step));
  return out_dir + name + suffix + ".json";
}

std::shared_ptr<const msspr::core::Dataset> LoadBags(const std::string& list,
                                                     const std::string& split,
                                                     const msspr::core::MsprOptions& options) {
  BagLoadOptions lo;
  lo.split = split;
  lo.images = options.network.obs_mode == "pixels";
  lo.robot = g_robot.get();
  lo.ns = g_ns;
  if (!g_ns.empty() && !g_robot)
    throw msspr::core::DatasetError("--ns " + g_ns + ": a namespace is for --robot's topics");
  if (g_robot) {
    if (lo.images && g_robot->images.empty())
      throw msspr::core::DatasetError(
          "--robot: " + g_robot->source +
          " names no camera (images:): a pixels policy needs one, or use --observation-mode state");
    if (split != "train")
      throw msspr::core::DatasetError("--robot: a robot's bags have no \"val\" split");
  }
  BagLoadReport report;
  auto data = std::make_shared<const msspr::core::Dataset>(
      msspr::agent::LoadBagDataset(SplitList(list), lo, &report));
  std::cerr << "msspr_train: " << split << " split of " << list << ": " << report.Summary() << "\n";
  for (size_t i = 0; i < report.problems.size() && i < 10; ++i)
    std::cerr << "msspr_train:   " << report.problems[i] << "\n";
  if (report.problems.size() > 10)
    std::cerr << "msspr_train:   ... and " << report.problems.size() - 10 << " more problems\n";
  for (const auto& u : report.usage) std::cerr << "msspr_train:   " << u << "\n";
  if (g_env.empty()) g_env = report.env;
  return data;
}

}  // namespace

namespace {

const char kEvalUsage[] =
    "\nEvaluation in the simulator (every --eval-every steps, when --eval-every > 0): the point\n"
    "maze, or the 5 tasks of cube-single, cube-double, an ant maze or a puzzle for those\n"
    "envs' bags\n"
    "  --eval-env ENV     env to evaluate in: pointmaze-NAME, cube-single, cube-double,\n"
    "                     antmaze-medium, antmaze-large, puzzle-3x3, puzzle-4x4 (default: the\n"
    "                     bags' env; give it for .npz data, e.g. OGBench's\n"
    "                     antmaze-medium-navigate-v0.npz with --eval-env antmaze-medium)\n"
    "  --eval-maze NAME   point maze to evaluate in (default: the bags' env, e.g. medium)\n"
    "  --eval-episodes N  episodes per task (default 50)\n"
    "  --eval-tasks LIST  task ids (default 1,2,3,4,5)\n"
    "  --eval-seed S      evaluation seed (default 0; same episodes as msspr_eval --seed S)\n"
    "  --eval-max-steps N step limit (default 1000; cube-single 200, cube-double and puzzles\n"
    "                     500)\n"
    "  --eval-tasks-file YAML  also evaluate custom start/goal pairs (msspr_eval --tasks-file\n"
    "                     format; msspr_make_tasks draws random ones), --eval-episodes each\n"
    "Each evaluation appends success_task<i> and mean_success to DIR/eval.csv and writes\n"
    "DIR/eval/step_<N>.json (the msspr_eval results format); with --eval-tasks-file also\n"
    "success_custom<id> and mean_success_custom, and DIR/eval/step_<N>_custom.json.\n"
    "\nA robot's own bags: --robot SPEC.yaml reads --data's bags of standard messages\n"
    "  (nav_msgs/Odometry, geometry_msgs/Twist, ...) through the robot interface spec (see\n"
    "  docs/bring_your_own_robot.md); checkpoints and policy.pt store the spec. The bags are\n"
    "  one recording in time order (rosbag record --split files join). --ns NS resolves the\n"
    "  spec's relative topics under NS (default: the spec's namespace:, else the one\n"
    "  namespace of the recording that holds them all).\n"
    "Example: rosrun msspr msspr_train --data medium-navigate.bag --scale cpu --steps 20000 \\\n"
    "           --eval-every 2000 --out runs/medium\n";

// The in-simulator evaluation flags (checked even when no evaluation runs: CliError, exit 2).
struct EvalFlags {
  msspr::agent::MazeEvalOptions maze;  // episodes, seed, max_steps, tasks (and maze, if one)
  std::optional<msspr::sim::EnvLabelParts> env;  // --eval-env, else the bags' env
  bool cube = false, ant = false, puzzle = false, cube_double = false, scene = false;
  std::string tasks_file;
};

EvalFlags ParseEvalFlags(const std::map<std::string, std::string>& extra) {
  auto get = [&](const std::string& k, const std::string& def) {
    auto it = extra.find(k);
    return it == extra.end() ? def : it->second;
  };
  using msspr::cli::ParseInt;
  EvalFlags f;
  msspr::agent::MazeEvalOptions& eo = f.maze;
  eo.episodes = static_cast<int>(ParseInt("eval-episodes", get("eval-episodes", "50"), 1, 1000000));
  eo.seed = static_cast<uint64_t>(ParseInt("eval-seed", get("eval-seed", "0"), 0));
  // The env to evaluate in: --eval-env, else the bags' env label ("pointmaze-medium",
  // "cube-single", "antmaze-medium"); none for a robot's own bags or .npz data without
  // --eval-env.
  f.env = msspr::sim::ParseEnvLabel(g_env);
  if (extra.count("eval-env")) {
    if (extra.count("eval-maze"))
      throw msspr::cli::CliError("give --eval-env or --eval-maze, not both");
    f.env = msspr::sim::ParseEnvLabel(get("eval-env", ""));
    if (!f.env)
      throw msspr::cli::CliError("--eval-env: '" + get("eval-env", "") +
                                 "' is not an env (pointmaze-arena|medium|large|giant, "
                                 "cube-single, cube-double, antmaze-medium, antmaze-large, "
                                 "scene, puzzle-3x3, puzzle-4x4)");
  }
  const bool no_maze = get("eval-maze", "").empty();
  f.cube = no_maze && f.env && f.env->id == msspr::sim::EnvId::kCubeSingle;
  f.ant = no_maze && f.env && msspr::sim::IsAntMaze(f.env->id);
  f.puzzle = no_maze && f.env && msspr::sim::IsPuzzle(f.env->id);
  f.cube_double = no_maze && f.env && f.env->id == msspr::sim::EnvId::kCubeDouble;
  f.scene = no_maze && f.env && f.env->id == msspr::sim::EnvId::kScene;
  // The env's cap, or a point maze's (--eval-maze).
  const int cap = no_maze && f.env ? msspr::sim::EvalEpisodeCap(f.env->id) : 1000;
  eo.max_steps = static_cast<int>(
      ParseInt("eval-max-steps", get("eval-max-steps", std::to_string(cap)), 1, 100000000));
  eo.tasks.clear();
  for (const auto& t : SplitList(get("eval-tasks", "1,2,3,4,5")))
    eo.tasks.push_back(static_cast<int>(ParseInt("eval-tasks", t, 1, 5)));
  if (eo.tasks.empty()) throw msspr::cli::CliError("--eval-tasks needs at least one task id");
  eo.maze = get("eval-maze", "");
  if (eo.maze.empty() && f.env && f.env->id == msspr::sim::EnvId::kPointMaze) eo.maze = f.env->maze;
  if (!eo.maze.empty()) {
    try {
      msspr::sim::MazeMap::FromName(eo.maze);
    } catch (const std::exception& e) {
      throw msspr::cli::CliError("--eval-maze: " + std::string(e.what()));
    }
  }
  f.tasks_file = get("eval-tasks-file", "");
  if ((f.cube || f.ant || f.puzzle || f.cube_double || f.scene) && extra.count("eval-tasks-file"))
    throw msspr::cli::CliError(
        "--eval-tasks-file: custom tasks are point-maze tasks (these bags are " +
        msspr::sim::EnvIdName(f.env->id) + ")");
  return f;
}

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// cube-single and the ant mazes: the env's tasks through `evaluate`, the results of each
// evaluation written by `write` to DIR/eval/step_<N>.json.
template <class Options, class Evaluate, class Write>
msspr::core::Evaluator TaskEvaluator(Options options, const EvalFlags& f, Evaluate evaluate,
                                     Write write, const std::string& out_dir,
                                     Clock::time_point start) {
  options.tasks = f.maze.tasks;
  options.episodes = f.maze.episodes;
  options.max_steps = f.maze.max_steps;
  options.seed = f.maze.seed;
  return [options, evaluate, write, out_dir, start](msspr::core::Policy& policy,
                                                    int64_t step) -> msspr::core::EvalResult {
    const auto result = evaluate(policy, options);
    msspr::core::EvalResult r;
    AddSuccessRows(result, "task", "", &r);
    r.emplace_back("eval_s", result.seconds);
    r.emplace_back("wall_s", Since(start));
    if (!out_dir.empty())
      write(result, options, "msspr step " + std::to_string(step), StepJsonPath(out_dir, step, ""));
    return r;
  };
}

// A point maze: its tasks, and with --eval-tasks-file the custom ones too.
msspr::core::Evaluator MazeEvaluator(const EvalFlags& f, const std::string& out_dir,
                                     Clock::time_point start) {
  const msspr::agent::MazeEvalOptions eo = f.maze;
  msspr::agent::MazeEvalOptions custom = eo;
  if (!f.tasks_file.empty()) {
    const auto map = msspr::sim::MazeMap::FromName(eo.maze);
    try {
      custom.custom_tasks = msspr::sim::LoadCustomTasks(f.tasks_file, &map);
    } catch (const std::runtime_error& e) {
      throw msspr::cli::CliError("--eval-tasks-file: " + std::string(e.what()));
    }
  }
  return [eo, custom, out_dir, start](msspr::core::Policy& policy,
                                      int64_t step) -> msspr::core::EvalResult {
    const auto result = msspr::agent::EvaluateOnMaze(policy, eo);
    msspr::core::EvalResult r;
    AddSuccessRows(result, "task", "", &r);
    double eval_s = result.seconds;
    if (!custom.custom_tasks.empty()) {
      const auto cr = msspr::agent::EvaluateOnMaze(policy, custom);
      AddSuccessRows(cr, "custom", "_custom", &r);
      eval_s += cr.seconds;
      if (!out_dir.empty())
        msspr::agent::WriteResultsJson(cr, custom, "msspr step " + std::to_string(step),
                                       StepJsonPath(out_dir, step, "_custom"));
    }
    r.emplace_back("eval_s", eval_s);
    r.emplace_back("wall_s", Since(start));
    if (!out_dir.empty())
      msspr::agent::WriteResultsJson(result, eo, "msspr step " + std::to_string(step),
                                     StepJsonPath(out_dir, step, ""));
    return r;
  };
}

// The success evaluation in the simulator of the bags' (or --eval-env's) env; none when
// eval_every is 0 or there is no simulated env.
msspr::core::Evaluator MakeSimEvaluator(msspr::core::Trainer& trainer,
                                        const std::map<std::string, std::string>& extra,
                                        const std::string& out_dir) {
  const EvalFlags f = ParseEvalFlags(extra);
  if (trainer.options().trainer.eval_every <= 0) return nullptr;
  const auto start = Clock::now();
  if (f.cube)
    return TaskEvaluator(msspr::agent::CubeEvalOptions(), f, msspr::agent::EvaluateOnCube,
                         msspr::agent::WriteCubeResultsJson, out_dir, start);
  if (f.cube_double)
    return TaskEvaluator(msspr::agent::ArmTaskEvalOptions(), f, msspr::agent::EvaluateOnCubeDouble,
                         msspr::agent::WriteCubeDoubleResultsJson, out_dir, start);
  if (f.scene)
    return TaskEvaluator(msspr::agent::ArmTaskEvalOptions(), f, msspr::agent::EvaluateOnScene,
                         msspr::agent::WriteSceneResultsJson, out_dir, start);
  if (f.puzzle) {
    msspr::agent::PuzzleEvalOptions po;
    po.side = msspr::sim::PuzzleSide(f.env->id);
    return TaskEvaluator(po, f, msspr::agent::EvaluateOnPuzzle,
                         msspr::agent::WritePuzzleResultsJson, out_dir, start);
  }
  if (f.ant) {
    msspr::agent::AntEvalOptions ao;
    ao.maze = msspr::sim::AntMazeName(f.env->id);
    return TaskEvaluator(ao, f, msspr::agent::EvaluateOnAntMaze, msspr::agent::WriteAntResultsJson,
                         out_dir, start);
  }
  if (f.maze.maze.empty()) {
    std::cerr << "msspr_train: no --eval-env or --eval-maze and no simulated env in the bags: no "
                 "success evaluation\n";
    return nullptr;
  }
  return MazeEvaluator(f, out_dir, start);
}

}  // namespace

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(
      argv);  // see process_env.h: OpenMP waits, OpenBLAS kernels
  msspr::core::TrainCliExtensions ext;
  ext.program = "msspr_train";
  std::vector<std::string> args;
  try {
    args = PrepareArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "msspr_train: --robot: " << e.what() << "\n";
    return 2;
  }
  ext.data_help =
      "msspr dataset bags (a.bag[,b.bag...] or a.bag b.bag; the \"train\" split) or an OGBench "
      ".npz";
  ext.extra_options = {"robot",          "ns",         "eval-env",  "eval-maze",
                       "eval-episodes",  "eval-tasks", "eval-seed", "eval-max-steps",
                       "eval-tasks-file"};
  ext.extra_usage = kEvalUsage;
  ext.load_dataset =
      [](const std::string& path, bool validation,
         const msspr::core::MsprOptions& options) -> std::shared_ptr<const msspr::core::Dataset> {
    if (!AllBags(path)) return nullptr;
    return LoadBags(path, validation ? "val" : "train", options);
  };
  ext.default_validation =
      [](const std::string& data_path,
         const msspr::core::MsprOptions& options) -> std::shared_ptr<const msspr::core::Dataset> {
    if (!AllBags(data_path) || g_robot) return nullptr;
    try {
      return LoadBags(data_path, "val", options);
    } catch (const msspr::core::DatasetError&) {
      std::cerr << "msspr_train: no \"val\" episodes in " << data_path
                << ": no validation losses\n";
      return nullptr;
    }
  };
  // out_dir/learning_curve.png after every evaluation and at the end.
  ext.after_eval = [](const std::string& out_dir) {
    msspr::sim::SaveLearningCurvePlot(out_dir + "/eval.csv", out_dir + "/metrics.csv",
                                      out_dir + "/learning_curve.png");
  };
  ext.make_evaluator = MakeSimEvaluator;
  std::vector<char*> cargv;
  for (auto& a : args) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  return msspr::core::RunTrainCli(static_cast<int>(args.size()), cargv.data(), ext);
}
