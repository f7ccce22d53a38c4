// msspr_policy_node: serves a trained Ms.PR policy (msspr_core::Policy) over
// ROS (docs/nodes.md "msspr_policy_node"). Takes observations (state, or camera
// images), a goal (the observation's goal field, a goal topic, or the
// ~set_goal service), and publishes actions, in lockstep (one action per
// observation) or at a fixed rate. This header does not include torch.
#pragma once

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "msspr/Observation.h"
#include "msspr/SetGoal.h"
#include "msspr_core/frame_stack.h"

namespace msspr::core {
class Policy;
}

namespace msspr::ros_bridge {

// The ROS logger name of the policy node (its own messages and the robot server's).
inline constexpr char kPolicyLog[] = "msspr_policy";

class ValueMarkers;

// How the node paces its actions (~stepping).
enum class Stepping { kLockstep, kRealtime };
inline const char* SteppingName(Stepping s) {  // "lockstep" | "realtime"
  return s == Stepping::kLockstep ? "lockstep" : "realtime";
}

struct PolicyNodeOptions {
  std::string checkpoint;  // required: Trainer::ExportPolicy file or full checkpoint
  // A robot interface spec (config/robots/*.yaml): serve over the robot's
  // standard topics through it (robot_server.h) instead of msspr/Observation and Action.
  std::string robot;
  std::string observation_mode = "state";  // state | pixels; must match the checkpoint
  // ~stepping: lockstep (one action per observation) | realtime (~rate Hz, on the newest
  // observation); the sim node's ~stepping takes the same words. ~mode (lockstep | rate) is
  // its deprecated spelling.
  Stepping stepping = Stepping::kLockstep;
  double rate = 10.0;                // Hz, realtime stepping
  double observation_timeout = 1.0;  // s; realtime stepping does not act on an older observation
  int threads = 1;                   // torch intra-op threads
  std::string device = "cpu";        // torch device of the policy
  double diagnostics_period = 1.0;   // s
  int latency_window = 1000;         // actions kept for the latency percentiles
  // V(s, g) over the free cells of this maze for the current goal, as markers
  // (state policies; "": off). Refreshed every value_marker_period s.
  std::string value_marker_maze;
  double value_marker_period = 2.0;
  int value_marker_per_cell = 2;  // points per cell per axis
};

// Reads ~params into PolicyNodeOptions and logs every value; throws
// std::invalid_argument on a missing checkpoint or a bad value.
PolicyNodeOptions LoadPolicyNodeOptions(const ros::NodeHandle& pnh);

// Sets torch's thread count to options.threads and loads options.checkpoint
// onto options.device; logs what the checkpoint holds. Throws
// std::runtime_error (core::CheckpointError) naming the file when it is
// missing, unreadable or corrupt, and std::invalid_argument when its
// observation mode is not options.observation_mode.
std::shared_ptr<core::Policy> LoadPolicyForNode(const PolicyNodeOptions& options);

// Why an input is refused; each reason has its own diagnostics counter.
enum class RejectReason { kWrongDim, kNonFinite, kNoGoal, kBadImage, kCount };
// Diagnostics key of a reason: rejected_wrong_dim, rejected_nonfinite,
// rejected_no_goal, rejected_bad_image.
const char* RejectKey(RejectReason reason);

class PolicyNode {
 public:
  // Takes the loaded policy. Throws std::invalid_argument when
  // options.observation_mode does not match the policy.
  PolicyNode(ros::NodeHandle nh, ros::NodeHandle pnh, const PolicyNodeOptions& options,
             std::shared_ptr<core::Policy> policy);
  ~PolicyNode();

  struct Counters {
    uint64_t observations = 0, images = 0, actions = 0;
    uint64_t rejected[static_cast<int>(RejectReason::kCount)] = {};
    uint64_t unmatched_images = 0;  // pixels: an observation or image whose partner never came
    uint64_t inference_errors = 0;  // the policy threw or returned NaN / Inf
  };
  const Counters& counters() const { return counters_; }

 private:
  // One observation ready for the policy: state, or frame-stacked image.
  struct Input {
    uint32_t episode_id = 0, step = 0;
    std_msgs::Header header;
    std::vector<float> state;         // [obs_dim] state mode
    std::vector<float> goal;          // [obs_dim] state mode
    std::vector<uint8_t> image;       // [H, W, C * frame_stack] pixels mode
    std::vector<uint8_t> goal_image;  // [H, W, C * frame_stack] pixels mode
    ros::WallTime received;
  };

  void OnObservation(const msspr::Observation::ConstPtr& msg);
  void OnImage(const sensor_msgs::ImageConstPtr& msg);
  void OnGoalImage(const sensor_msgs::ImageConstPtr& msg);
  void OnGoalState(const msspr::Observation::ConstPtr& msg);
  bool OnSetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res);
  void OnRateTick(const ros::WallTimerEvent&);
  void OnDiagnostics(const ros::WallTimerEvent&);
  void OnValueMarkers(const ros::WallTimerEvent&);

  // Counts a rejection; the first of each reason is logged at once with what the
  // checkpoint expects, later ones throttled.
  void Reject(RejectReason reason, const std::string& what);
  bool said_[static_cast<int>(RejectReason::kCount)] = {};
  // Checks a state observation and resolves its goal; false (counted) when unusable.
  bool MakeStateInput(const msspr::Observation& msg, Input* in);
  // Pixels: pairs observations and images by stamp; builds the input of a pair.
  void TryPair();
  bool MakePixelInput(const msspr::Observation& obs, const sensor_msgs::Image& img, Input* in);
  // Runs the policy on `in`, publishes the action; `start` is when handling began.
  void Act(const Input& in, const ros::WallTime& start);

  PolicyNodeOptions options_;
  ros::NodeHandle nh_, pnh_;
  std::shared_ptr<core::Policy> policy_;
  int obs_dim_ = 0, action_dim_ = 0;
  int image_h_ = 0, image_w_ = 0, image_c_ = 0, frame_stack_ = 1;
  bool pixels_ = false;

  image_transport::ImageTransport it_;
  ros::Subscriber obs_sub_, goal_state_sub_;
  image_transport::Subscriber image_sub_, goal_image_sub_;
  ros::Publisher action_pub_, diag_pub_;
  ros::ServiceServer set_goal_srv_;
  ros::WallTimer rate_timer_, diag_timer_, value_timer_;
  ros::Publisher value_pub_;
  std::unique_ptr<ValueMarkers> value_markers_;  // ~value_marker_maze (value_markers.h)
  std::vector<float> last_goal_;                 // the goal of the latest action (state mode)

  // Goal override (state mode): set by ~set_goal or the goal_state topic; an
  // empty goal clears it and the observation's goal field applies again.
  std::vector<float> goal_override_;
  std::string goal_source_ = "observation";
  std::vector<uint8_t> goal_image_;  // [H, W, C * frame_stack] pixels mode (empty: none yet)

  // Pixels: recent unpaired observations and images (by stamp), and the frame history.
  std::deque<msspr::Observation::ConstPtr> pending_obs_;
  std::deque<sensor_msgs::ImageConstPtr> pending_images_;
  std::optional<msspr::core::FrameStacker> frames_;  // the episode's last frame_stack images
  int64_t frames_episode_ = -1, frames_step_ = -1;

  // Rate mode: the latest good input.
  std::unique_ptr<Input> latest_;

  // Diagnostics.
  Counters counters_;
  std::deque<double> latencies_ms_;
  uint64_t actions_at_last_diag_ = 0;
  uint64_t rejected_at_last_diag_ = 0;
  ros::WallTime last_diag_time_;
  bool value_due_ = true;  // compute Q of the next action (once per diagnostics period)
  double value_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace msspr::ros_bridge
