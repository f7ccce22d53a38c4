// What an in-process evaluation (maze_evaluator.h, cube_evaluator.h) reports
// per task, and its conversion to msspr_eval's report (the results JSON).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "msspr_sim/cube_failures.h"
#include "msspr_sim/eval_protocol.h"

namespace msspr::agent {

// How many episodes the MuJoCo evaluators (the arm's envs, the ant) run side by side by default.
// Each holds an env of its own: an arm env (its MuJoCo model with the meshes, and its data)
// takes about 13 MB, the ant's about 3 MB, so the protocol's 5 x 50 episodes at once held 3.5 GB
// for the scene. More side by side saves nothing: Policy::Act computes each row on its own, so
// outcomes do not depend on it.
inline constexpr int kEpisodesAtOnce = 50;

// One episode of an evaluation.
struct EpisodeResult {
  bool success = false;
  int steps = 0;                  // control steps taken
  std::vector<double> final_obs;  // the state observation it ended in
  // cube-single: the cube's rise and where it ended against the goal (how the
  // episode failed, sim::CountCubeFailures); empty in other envs.
  std::optional<sim::CubeOutcome> cube = std::nullopt;
};

struct TaskSuccessResult {
  std::vector<int> tasks;
  std::vector<double> success;             // per task, in [0, 1]
  std::vector<double> mean_steps_success;  // per task, steps of the successful episodes
  double mean_success = 0.0;
  double seconds = 0.0;
  // Every episode, task by task (episode e of task i at i * episodes + e);
  // filled by EvaluateOnMaze, EvaluateOnCube and EvaluateOnAntMaze.
  std::vector<EpisodeResult> episodes;
};

// The result of tasks.size() x episodes episodes laid out task by task (episode e of
// task i at i * episodes + e): success per task, the mean steps of its successful
// episodes, mean_success over the tasks, the episodes themselves; seconds left 0.
inline TaskSuccessResult SummarizeTaskEpisodes(const std::vector<int>& tasks, int episodes,
                                               std::vector<EpisodeResult> results) {
  TaskSuccessResult r;
  r.tasks = tasks;
  const size_t nt = tasks.size();
  r.success.assign(nt, 0.0);
  r.mean_steps_success.assign(nt, 0.0);
  for (size_t ti = 0; ti < nt; ++ti) {
    int ok = 0;
    for (int e = 0; e < episodes; ++e) {
      const EpisodeResult& ep =
          results[ti * static_cast<size_t>(episodes) + static_cast<size_t>(e)];
      if (ep.success) {
        ++ok;
        r.mean_steps_success[ti] += ep.steps;
      }
    }
    r.success[ti] = episodes > 0 ? static_cast<double>(ok) / episodes : 0.0;
    if (ok) r.mean_steps_success[ti] /= ok;
    r.mean_success += r.success[ti] / static_cast<double>(nt);
  }
  r.episodes = std::move(results);
  return r;
}

// The report (starts and goals left empty), mean_success filled.
inline sim::EvalReport MakeTaskReport(const TaskSuccessResult& r, const std::string& env,
                                      const std::string& agent, int episodes, int max_steps,
                                      uint64_t seed) {
  sim::EvalReport report;
  report.env = env;
  report.agent = agent;
  report.episodes_per_task = episodes;
  report.max_steps = max_steps;
  report.seed = seed;
  report.wall_time_s = r.seconds;
  for (size_t i = 0; i < r.tasks.size(); ++i) {
    sim::TaskResult t;
    t.task_id = r.tasks[i];
    t.success = r.success[i];
    t.episodes = episodes;
    t.mean_steps_successful = r.mean_steps_success[i];
    report.tasks.push_back(t);
  }
  sim::FinalizeReport(&report);
  return report;
}

}  // namespace msspr::agent
