// What an in-process evaluation (maze_evaluator.h, cube_evaluator.h) reports
// per task, and its conversion to msspr_eval's report (the results JSON).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_sim/eval_protocol.h"

namespace msspr::agent {

struct TaskSuccessResult {
  std::vector<int> tasks;
  std::vector<double> success;             // per task, in [0, 1]
  std::vector<double> mean_steps_success;  // per task, steps of the successful episodes
  double mean_success = 0.0;
  double seconds = 0.0;
};

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
