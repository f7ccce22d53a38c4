// The scene's play oracle and play episodes (OGBench's scene-play): after each plan a subtask
// drawn with weights cube 1 (0 while the cube is in the drawer), button 1, drawer 0.25 if
// locked else 1, window 0.25 if locked else 1, and its plan:
// - cube: into the open drawer's tray (the drawer beyond -0.12 and U < 0.3: the tray centre
//   (0.33, -0.24, 0.066) + U(-0.005, 0.005) in x and y, as OGBench's with the drawer open),
//   else a random xy of the object box; OGBench's cube plan (PlanPickAndPlace);
// - button: one of the two, OGBench's button plan with the gripper open at its ends;
// - drawer: open (-0.16) when closed beyond -0.08, else closed; window: open (0.2) when below
//   0.1, else closed: OGBench's handle plan (approach 0.12 m (drawer) or 0.06 m (window)
//   above the handle, grasp, drag to the target handle position, release, clear, a random
//   final pose), at the handle's yaw + k pi nearest the effector's.
// A locked drawer or window still gets its attempts, as OGBench's data holds pulls that do not
// move. Episodes whose cube leaves the table's sight (y >= 0.29, or y <= -0.30 outside the
// tray's z 0.06-0.08) are drawn again from another seed, as OGBench's health check does.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/cube_oracle.h"
#include "msspr_sim/puzzle_oracle.h"
#include "msspr_sim/scene_env.h"

namespace msspr::sim {

struct SceneOracleOptions {
  CubePlayOracleOptions cube;  // the cube plan (cube-single's)
  PuzzleOracleOptions button;  // the button plan (jitter 0.04 s)
  CubePlayOracleOptions handle{0.05, 0.04, 0.1, {0.05, 0.05, 0.05, 0.3, 1.0}};
};

// OGBench's handle plan for a slide whose handle is at `handle` (yaw `handle_yaw`), dragged to
// `target`; `above` m of approach and clearance.
std::vector<CubePlanSample> PlanHandleMove(const ArmEnv& env, const Eigen::Vector3d& handle,
                                           double handle_yaw, const Eigen::Vector3d& target,
                                           double above, const CubePlayOracleOptions& options,
                                           std::mt19937_64& rng);

class ScenePlayOracle {
 public:
  enum class Subtask { kCube, kButton, kDrawer, kWindow };
  explicit ScenePlayOracle(uint64_t seed, const SceneOracleOptions& options = {});
  SceneEnv::Action Act(SceneEnv& env);
  Subtask subtask() const { return subtask_; }
  int cycles() const { return cycles_; }

 private:
  SceneOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  int cycles_ = 0;
  Subtask subtask_ = Subtask::kCube;
};

// Solves a scene evaluation task from the env's goal state, one plan at a time, each chosen
// from the state when the last ends (NextStep), in this order:
// 1. the cube, unless at its goal: for a goal in the drawer, the drawer opened (unlocked
//    first) and the cube put in its tray; for a goal on the table, the cube taken there (out
//    of the opened drawer if it is inside);
// 2. the drawer to its goal slide, unlocked first (a cube in the tray rides to its goal);
// 3. the window likewise;
// 4. each button whose state differs pressed.
// The plans are the play oracle's (its noise included); a plan that fails is chosen again.
// Once everything is at its goal it holds the pinch still.
class SceneTaskOracle {
 public:
  enum class Subtask { kNone, kCube, kButton, kDrawer, kWindow };
  struct Step {
    Subtask subtask;
    int button;     // kButton: which
    double target;  // kDrawer, kWindow: the slide's target (m)
  };
  static constexpr double kPlaced = 0.02;             // m: the cube, drawer or window "at goal"
  static constexpr double kDrawerOpenEnough = -0.12;  // m: the tray reachable
  static constexpr double kInDrawerY = -0.3;          // a cube goal below this y is in the drawer
  // Where the cube goes in the open tray: (0.33, the handle's y - 0.16, 0.066), as the play
  // oracle's tray target.
  static constexpr double kTrayX = 0.33, kTrayFromHandle = -0.16, kTrayZ = 0.066;

  explicit SceneTaskOracle(uint64_t seed, const SceneOracleOptions& options = {});
  SceneEnv::Action Act(const SceneEnv& env);
  // The plan to make next from env's state (what Act does once a plan ends).
  Step NextStep(const SceneEnv& env) const;
  const Step& current() const { return current_; }

 private:
  SceneOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  Step current_{Subtask::kNone, -1, 0.0};
};

using SceneCollectOptions = PlayCollectOptions<SceneOracleOptions>;

// Episode `index` of scene-play: env.ResetForCollection(seed), the play oracle seeded from it,
// with seed EpisodeSeed(seed, index), then (after an unhealthy episode) Mix64 of it and the
// attempt, up to 20 attempts (std::runtime_error after). The episode's `seed` is the one used,
// so a replay from ResetForCollection(seed) reproduces the rows.
PlayEpisode CollectSceneEpisode(SceneEnv& env, const SceneCollectOptions& options, uint64_t index);

}  // namespace msspr::sim
