// In-process evaluation of a Policy on cube-single by OGBench's protocol (no
// ROS): the 5 tasks' resets with the same seeds as msspr_eval --env cube-single
// over ROS (sim::EvalEpisodeSeed), up to max_steps steps, success when the cube
// is within 4 cm of the goal (the episode ends there, as over ROS). All
// episodes run side by side, one policy call per control step, each episode's
// action computed on its own (Policy::Act), so outcomes do not depend on the
// thread count or the number of episodes. Pixels policies see 64x64 camera
// images (front_pixels, the pixel-mode look, as msspr_sim_node's
// observation_mode pixels and msspr_collect --images give them) and the goal's
// image, rendered through one rendering context.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_eval/eval_result.h"

namespace msspr::core {
class Policy;
}

namespace msspr::agent {

struct CubeEvalOptions {
  std::string urdf_path;  // the arm; empty: sim::DefaultArmUrdf() (package_files.h)
  std::vector<int> tasks = {1, 2, 3, 4, 5};
  int episodes = 50;  // per task
  int max_steps = 200;
  uint64_t seed = 0;  // episode e of task t: sim::EvalEpisodeSeed(seed, t, e), as msspr_eval
};

using CubeEvalResult = TaskSuccessResult;

// Runs the evaluation. Throws std::invalid_argument on a bad task or when the
// policy does not fit cube-single (28-D states or square RGB images, 5-D actions).
CubeEvalResult EvaluateOnCube(core::Policy& policy, const CubeEvalOptions& options);

// The cube's outcome of each episode (how the failed ones failed:
// sim::CountCubeFailures, sim::DescribeCubeFailures).
std::vector<sim::CubeOutcome> CubeOutcomes(const CubeEvalResult& result);

// The results in msspr_eval's report format (env "cube-single").
sim::EvalReport MakeCubeEvalReport(const CubeEvalResult& result, const CubeEvalOptions& options,
                                   const std::string& agent);
// Writes the results JSON shared with msspr_eval; throws std::runtime_error naming the path.
void WriteCubeResultsJson(const CubeEvalResult& result, const CubeEvalOptions& options,
                          const std::string& agent, const std::string& path);

}  // namespace msspr::agent
