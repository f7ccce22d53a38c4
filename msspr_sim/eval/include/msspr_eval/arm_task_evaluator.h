// In-process evaluation of a state Policy on the arm's tasks beyond cube-single (puzzle-3x3,
// puzzle-4x4, cube-double, scene) by OGBench's protocol (no ROS): the 5 tasks' resets with the
// evaluation seeds of every msspr evaluator (sim::EvalEpisodeSeed), up to max_steps steps
// (OGBench's caps: 500; the scene 750), success as the env's (the episode ends there). Episodes run
// side by side, episodes_at_once at a time, each action computed on its own (Policy::Act), as the
// cube's evaluator (cube_evaluator.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_eval/eval_result.h"

namespace msspr::core {
class Policy;
}

namespace msspr::agent {

// The evaluation of an arm task (cube-double, the scene; the puzzles' with their side).
struct ArmTaskEvalOptions {
  std::string urdf_path;  // the arm; empty: sim::DefaultArmUrdf() (package_files.h)
  std::vector<int> tasks = {1, 2, 3, 4, 5};
  int episodes = 50;  // per task
  int max_steps = 0;  // steps per episode; 0: the env's cap (500; the scene 750)
  uint64_t seed = 0;  // episode e of task t: sim::EvalEpisodeSeed(seed, t, e)
  // Episodes side by side, each with its env (about 13 MB); the outcomes do not depend on it.
  int episodes_at_once = kEpisodesAtOnce;
};

struct PuzzleEvalOptions : ArmTaskEvalOptions {
  int side = 3;  // 3: puzzle-3x3, 4: puzzle-4x4
};

using PuzzleEvalResult = TaskSuccessResult;

// Runs the evaluation. Throws std::invalid_argument on a bad side or task, for a pixels
// policy, or when the policy does not fit the puzzle (19 + 4 N states, 5-D actions).
PuzzleEvalResult EvaluateOnPuzzle(core::Policy& policy, const PuzzleEvalOptions& options);

// The results in msspr_eval's report format (env "puzzle-3x3" or "puzzle-4x4"; each task's
// start and goal are its boards' states, row by row).
sim::EvalReport MakePuzzleEvalReport(const PuzzleEvalResult& result,
                                     const PuzzleEvalOptions& options, const std::string& agent);
// Writes the results JSON; throws std::runtime_error naming the path.
void WritePuzzleResultsJson(const PuzzleEvalResult& result, const PuzzleEvalOptions& options,
                            const std::string& agent, const std::string& path);

using ArmTaskEvalResult = TaskSuccessResult;

// cube-double (37-D states, 5-D actions); throws std::invalid_argument as EvaluateOnPuzzle.
ArmTaskEvalResult EvaluateOnCubeDouble(core::Policy& policy, const ArmTaskEvalOptions& options);
// The scene (40-D states, 5-D actions); throws std::invalid_argument as EvaluateOnPuzzle.
ArmTaskEvalResult EvaluateOnScene(core::Policy& policy, const ArmTaskEvalOptions& options);

// The reports (env "cube-double", "scene") and their JSON (std::runtime_error naming the path).
sim::EvalReport MakeCubeDoubleEvalReport(const ArmTaskEvalResult& result,
                                         const ArmTaskEvalOptions& options,
                                         const std::string& agent);
void WriteCubeDoubleResultsJson(const ArmTaskEvalResult& result, const ArmTaskEvalOptions& options,
                                const std::string& agent, const std::string& path);
sim::EvalReport MakeSceneEvalReport(const ArmTaskEvalResult& result,
                                    const ArmTaskEvalOptions& options, const std::string& agent);
void WriteSceneResultsJson(const ArmTaskEvalResult& result, const ArmTaskEvalOptions& options,
                           const std::string& agent, const std::string& path);

}  // namespace msspr::agent
