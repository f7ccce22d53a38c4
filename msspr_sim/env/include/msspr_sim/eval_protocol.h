// The evaluation protocol shared by msspr_eval (over ROS) and the trainer's
// in-process evaluator, so that both see the same episodes.
#ifndef MSSPR_SIM_EVAL_PROTOCOL_H_
#define MSSPR_SIM_EVAL_PROTOCOL_H_

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"

namespace msspr::sim {

// Seed of episode `episode` (0-based) of evaluation task `task` (1..5):
// PointMaze::ResetToTask(task, EvalEpisodeSeed(seed, task, episode)).
inline uint64_t EvalEpisodeSeed(uint64_t seed, int task, int episode) {
  return EpisodeSeed(seed, static_cast<uint64_t>(task) * 100000u + static_cast<uint64_t>(episode));
}

struct TaskResult {
  int task_id = 0;
  double success = 0.0;  // fraction of episodes that reached the goal
  int episodes = 0;
  double mean_steps_successful = 0;  // steps to the goal, over the successful episodes
  std::vector<double> start, goal;   // custom tasks only: exact start and goal (x, y)
};

// The results of one evaluation, as msspr_eval and the trainer write them.
struct EvalReport {
  std::string env;  // "pointmaze-medium"
  std::string agent;
  std::string robot;             // the robot interface spec served through ("": msspr's own topics)
  std::string observation_mode;  // what the agent was served: "state", "pixels" ("": unstated)
  int episodes_per_task = 0, max_steps = 1000;
  uint64_t seed = 0;
  std::vector<TaskResult> tasks;
  double mean_success = 0.0;  // mean over tasks, in [0, 1]
  int stalled_episodes = 0;
  double wall_time_s = 0.0;
};

// The episode flags msspr_eval and msspr_eval_inprocess share, from a command line
// (msspr::cli::CliArgs): --episodes (default 50), --max-steps (`default_max_steps`), --seed
// (0) and, with `read_tasks`, --tasks (default 1,2,3,4,5, each in 1..`num_tasks`). Throws
// the command line's usage errors.
struct EpisodeFlags {
  std::vector<int> tasks;
  int episodes = 50, max_steps = 1000;
  uint64_t seed = 0;
};
template <class Args>
EpisodeFlags ReadEpisodeFlags(const Args& args, int default_max_steps, long num_tasks,
                              bool read_tasks = true) {
  EpisodeFlags f;
  if (read_tasks) {
    for (long t : args.GetIntList("tasks", "1,2,3,4,5", 1, num_tasks))
      f.tasks.push_back(static_cast<int>(t));
  }
  f.episodes = static_cast<int>(args.GetInt("episodes", 50, 1, 1000000));
  f.max_steps = static_cast<int>(args.GetInt("max-steps", default_max_steps, 1, 100000000));
  f.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
  return f;
}

// Fills mean_success from the tasks.
void FinalizeReport(EvalReport* report);
// The results JSON ({env, agent, ..., tasks: [{task_id, start_cell, goal_cell, success, ...}],
// mean_success}); task cells come from `map`.
std::string EvalReportJson(const MazeMap& map, const EvalReport& report);
// The same for reports whose tasks all carry their start and goal (cube-single).
std::string EvalReportJson(const EvalReport& report);
// A per-task table for terminals (with and without a map, as above).
std::string EvalReportTable(const MazeMap& map, const EvalReport& report);
std::string EvalReportTable(const EvalReport& report);
// Writes text to path, creating parent directories; throws std::runtime_error naming the path.
void WriteTextFile(const std::string& path, const std::string& text);
// Bar chart of success per task (PNG, OpenCV); throws std::runtime_error naming the path.
void SaveSuccessPlot(const EvalReport& report, const std::string& png_path);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_EVAL_PROTOCOL_H_
