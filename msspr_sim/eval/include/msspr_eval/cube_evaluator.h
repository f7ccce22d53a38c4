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

// How the failed episodes of a cube-single evaluation failed: the cube never
// lifted (it rose less than kLiftedCm above its start: no grasp), or lifted and
// ended away from the goal (a grasp, no placement within 4 cm).
struct CubeFailures {
  static constexpr double kLiftedCm = 2.0;
  int episodes = 0, failed = 0;
  int never_lifted = 0;
  int lifted_not_placed = 0;
  double median_miss_cm = 0;    // final cube-goal distance of the lifted failures (0: none)
  double median_above_cm = 0;   // of that, the height above the goal (held up, not set down)
  double median_across_cm = 0;  // and the horizontal distance
};
CubeFailures CountCubeFailures(const CubeEvalResult& result);
// "failures: 62 of 250 episodes: 40 never lifted the cube 2 cm (no grasp), 22
// lifted it and ended a median 7.5 cm from the goal (6.1 cm across, 3 cm above)"
std::string DescribeCubeFailures(const CubeFailures& f);

// The results in msspr_eval's report format (env "cube-single").
sim::EvalReport MakeCubeEvalReport(const CubeEvalResult& result, const CubeEvalOptions& options,
                                   const std::string& agent);
// Writes the results JSON shared with msspr_eval; throws std::runtime_error naming the path.
void WriteCubeResultsJson(const CubeEvalResult& result, const CubeEvalOptions& options,
                          const std::string& agent, const std::string& path);

}  // namespace msspr::agent
