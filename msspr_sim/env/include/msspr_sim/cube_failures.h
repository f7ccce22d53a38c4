// How a cube-single episode failed, from its observations: the cube never
// lifted (no grasp), or it was lifted and ended away from the goal (a grasp
// without a placement within 4 cm), with how far across and above. The same
// counts in process (msspr_eval_inprocess) and over ROS (msspr_eval), so a
// weak policy shows whether it cannot grasp or cannot place. No ROS, no torch.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace msspr::sim {

// One episode's cube, in metres.
struct CubeOutcome {
  bool success = false;
  double lift = 0;           // the most the cube rose above where it started
  double goal_distance = 0;  // its centre's final distance to the goal's
  double above_goal = 0;     // of that, the height above the goal (which rests on the table)
  // The gripper's final distance to the goal observation's gripper (the goal is a whole
  // observation: a cube and an arm; only the cube decides success).
  double gripper_to_goal_gripper = 0;
  // The cube's final offset from the goal along the table's line from where it started to
  // the goal: negative stopped short of the goal, positive went past it.
  double along_start_to_goal = 0;
};

// Follows one episode's 28-D cube-single observations (CubeEnv::GetObservation).
class CubeEpisodeTracker {
 public:
  // The episode's first observation and its goal observation.
  void Start(const float* obs, const float* goal_obs);
  // Each later observation, in order.
  void Observe(const float* obs);
  // The outcome, from the last observation seen.
  CubeOutcome Finish(bool success) const;

 private:
  double start_z_ = 0, lift_ = 0;
  Eigen::Vector3d last_ = Eigen::Vector3d::Zero(), goal_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d last_pinch_ = Eigen::Vector3d::Zero(), goal_pinch_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d start_ = Eigen::Vector3d::Zero();
};

struct CubeFailures {
  static constexpr double kLiftedCm = 2.0;  // a rise below this is no grasp
  int episodes = 0, failed = 0;
  int never_lifted = 0;
  int lifted_not_placed = 0;
  // Medians over the lifted failures (0 when there are none): the final
  // distance to the goal, and its horizontal and vertical parts; the gripper's
  // final distance to the goal observation's gripper.
  double median_miss_cm = 0, median_across_cm = 0, median_above_cm = 0;
  double median_gripper_cm = 0;
  double median_along_cm = 0;  // signed: negative stopped short of the goal
};
CubeFailures CountCubeFailures(const std::vector<CubeOutcome>& outcomes);
// "failures: 62 of 250 episodes: 40 never lifted the cube 2.0 cm (no grasp), 22
// lifted it and ended a median 7.5 cm from the goal (6.1 cm across, 3.0 cm above, 4.0 cm
// short of it on the way from its start; the gripper a median 12.0 cm from the goal's)"
std::string DescribeCubeFailures(const CubeFailures& f);

}  // namespace msspr::sim
