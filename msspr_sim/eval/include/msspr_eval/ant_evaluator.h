// In-process evaluation of a Policy on an ant maze (antmaze-medium,
// antmaze-large) by OGBench's protocol, without ROS: the maze's 5 tasks with
// the seeds of msspr_eval (sim::EvalEpisodeSeed), the 29-D goal state of
// AntMaze's goal construction, up to max_steps control steps, success when
// the torso is within 0.5 m of the goal's xy (the episode ends there). Episodes
// run side by side, episodes_at_once at a time: one policy call per control step, each
// episode's action computed on its own (Policy::Act), so outcomes do not
// depend on the thread count or the number of episodes.
// State policies only (29-D observations, 8-D actions).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_eval/eval_result.h"

namespace msspr::core {
class Policy;
}

namespace msspr::agent {

struct AntEvalOptions {
  std::string maze = "medium";  // "medium" or "large" (sim::AntMazeName)
  std::vector<int> tasks = {1, 2, 3, 4, 5};
  int episodes = 50;  // per task
  int max_steps = 1000;
  uint64_t seed = 0;  // episode e of task t: sim::EvalEpisodeSeed(seed, t, e), as msspr_eval
  // Episodes side by side, each with its env (about 3 MB); the outcomes do not depend on it.
  int episodes_at_once = kEpisodesAtOnce;
};

using AntEvalResult = TaskSuccessResult;

// Runs the evaluation. Throws std::invalid_argument on a bad maze or task, or
// when the policy's dimensions do not fit the ant (29-D states, 8-D actions).
AntEvalResult EvaluateOnAntMaze(core::Policy& policy, const AntEvalOptions& options);

// The results in msspr_eval's report format (env "antmaze-medium" / "antmaze-large";
// each task's start and goal cell centres, metres).
sim::EvalReport MakeAntEvalReport(const AntEvalResult& result, const AntEvalOptions& options,
                                  const std::string& agent);
// Writes the results JSON shared with msspr_eval; throws std::runtime_error naming the path.
void WriteAntResultsJson(const AntEvalResult& result, const AntEvalOptions& options,
                         const std::string& agent, const std::string& path);

}  // namespace msspr::agent
