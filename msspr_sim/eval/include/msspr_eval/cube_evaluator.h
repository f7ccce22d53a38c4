// In-process evaluation of a Policy on cube-single by OGBench's protocol (no
// ROS): the 5 tasks' resets with the same seeds as msspr_eval --env cube-single
// over ROS (sim::EvalEpisodeSeed), up to max_steps steps, success when the cube
// is within 4 cm of the goal (the episode ends there, as over ROS). Episodes
// run side by side, episodes_at_once at a time, one policy call per control step, each episode's
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
#include "msspr_sim/cube_env.h"

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
  // Episodes side by side, each with its env (about 13 MB); the outcomes do not depend on it.
  int episodes_at_once = kEpisodesAtOnce;
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

// What the critic believes about a placement: its value V(s, g) (Ms.PR: the
// lower twin Q of the policy's action; gcivl, gciql, hiql: their values, in the
// same return units) of a state s whose cube rests at a task's goal, for goals
// whose cube is moved `shift` cm away in the table's plane, in `directions`
// directions. The goal is the goal observation of a reset to the task (a
// random arm, the cube at rest at the goal); the state is that observation
// itself ("same arm": only the cube's shift differs) or the goal observation
// of another reset ("another arm", as at the end of an episode), or the cube
// held by the gripper 5 cm above the goal ("carrying", CarryOverGoal), where
// the probe also asks whether the actor steers toward the moved goal. Success
// needs the cube within 4 cm; the goal observation also holds an arm, which
// the agents' hindsight goals teach them to reach too.
struct CubeGoalShiftOptions {
  std::string urdf_path;  // the arm; empty: sim::DefaultArmUrdf()
  std::vector<double> shifts_cm = {0, 1, 2, 3, 4, 5, 6, 8, 10};
  int pairs_per_task = 20;  // goals (and states of another arm) per task, tasks 1-5
  int directions = 8;       // evenly spaced in the table's plane
  uint64_t seed = 0;
};

struct CubeGoalShiftValues {
  std::vector<double> mean;  // V over the goals and directions, per shift
  std::vector<double> sd;
  // The steps to go that `mean` stands for with the agent's discount
  // (V = -(1 - gamma^n) / (1 - gamma)); infinity at or below -1/(1-gamma).
  std::vector<double> steps;
  // Carrying only: the mean cosine between the action's horizontal move
  // (actions 0 and 1) and the direction the goal's cube was moved: 1 steers
  // straight to it, 0 ignores it (NaN at shift 0).
  std::vector<double> steer;
};

struct CubeGoalShiftResult {
  std::vector<double> shifts_cm;
  CubeGoalShiftValues same_arm, other_arm, carrying;
  int samples = 0;  // values per shift and variant: 5 x pairs_per_task x directions
  double gamma = 0.99;
};

// Resets env to `task` with `seed`, puts the cube at rest at the goal and grasps
// it with the scripted moves of the play oracle (down open, close, up), ending
// with the cube held `height` m above where it rested; returns the observation.
sim::CubeEnv::Observation CarryOverGoal(sim::CubeEnv& env, int task, uint64_t seed,
                                        double height = 0.05);

// Throws std::invalid_argument when the policy has no value (gcbc), reads
// pixels, or does not fit cube-single's 28-D states and 5-D actions.
CubeGoalShiftResult ProbeCubeGoalShifts(core::Policy& policy, const CubeGoalShiftOptions& options);

}  // namespace msspr::agent
