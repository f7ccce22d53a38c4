// The robot interface spec: one YAML file per robot that says what
// the policy's observation is (an ordered list of fields of standard ROS
// messages), what its action means (fields of the command message), where the
// goal comes from, the control rate, time alignment and episode boundaries.
// The same spec drives training from the robot's bags (spec_bag.h) and serving
// on the robot (msspr_policy_node ~robot). docs/bring_your_own_robot.md
// describes the format; config/robots/ holds the shipped specs.
//
// This header and robot_spec.cc include no ROS header (yaml-cpp only).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::ros_bridge {

// A spec that cannot be read or is wrong; what() names the spec file and, where
// it applies, the topic and the field.
class RobotSpecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Message types a field may be read from.
inline constexpr const char* kOdometryType = "nav_msgs/Odometry";
inline constexpr const char* kPoseStampedType = "geometry_msgs/PoseStamped";
inline constexpr const char* kTwistType = "geometry_msgs/Twist";
inline constexpr const char* kTwistStampedType = "geometry_msgs/TwistStamped";
inline constexpr const char* kJointStateType = "sensor_msgs/JointState";
inline constexpr const char* kFloat64MultiArrayType = "std_msgs/Float64MultiArray";
inline constexpr const char* kJointTrajectoryType = "trajectory_msgs/JointTrajectory";
// An observation field read from tf2 (/tf and /tf_static): the transform
// between two frames, as geometry_msgs/TransformStamped (translation, rotation).
inline constexpr const char* kTf2Type = "tf2";
// The topic name under which a spec's tf2 fields are grouped (bags: /tf and /tf_static).
inline constexpr const char* kTf2Topic = "tf";
// Camera images (the `images:` section and image goals).
inline constexpr const char* kImageType = "sensor_msgs/Image";
inline constexpr const char* kCompressedImageType = "sensor_msgs/CompressedImage";

// One field of a message: a run of numbers the observation (or action) takes.
struct SpecField {
  std::string name;   // unique within the observation / action; names it in errors
  std::string topic;  // observation fields: the topic (the action has one topic)
  std::string type;   // message type, e.g. nav_msgs/Odometry
  // Path inside the message: a number (pose.pose.position.x), a group of them
  // (pose.pose.position: x, y, z; twist.twist.linear), JointState position /
  // velocity / effort (with `joints`), Float64MultiArray data[a:b] or data[i],
  // JointTrajectory points[0].positions / points[0].velocities (with `joints`).
  std::string field;
  std::vector<std::string> components;  // subset of a group, in this order (empty: all)
  std::vector<std::string> joints;      // JointState / JointTrajectory: by name, in this order
  // type tf2: [parent, child]: the child frame's pose in the parent frame
  // (tf2 lookupTransform(parent, child)); fields translation / rotation.
  std::vector<std::string> frames;
  // "" or "yaw" (1 value) or "yaw_cos_sin" (2 values: cos, sin) of a quaternion field.
  std::string derive;
  // Observation: value = scale * (raw - offset). Action: command = offset + scale * a.
  // One number for all values, or one per value.
  std::vector<double> scale = {1.0};
  std::vector<double> offset = {0.0};
  // Action: a in [clip[0], clip[1]] before scaling (training: after unscaling).
  // Observation (only with has_clip): the value after scale and offset is clipped.
  std::vector<double> clip = {-1.0, 1.0};
  bool has_clip = false;  // observation fields: `clip` given
  // Which stamp a message carries: "header" (header.stamp; types with a header)
  // or "receipt" (when it was received / recorded; the only one of Twist and
  // Float64MultiArray).
  std::string stamp;

  // Numbers this field contributes (after `derive`).
  int size() const;
  double ScaleAt(int i) const { return scale.size() == 1 ? scale[0] : scale[i]; }
  double OffsetAt(int i) const { return offset.size() == 1 ? offset[0] : offset[i]; }
};

// A camera: a topic of sensor_msgs/Image (encodings rgb8, bgr8, mono8) or
// sensor_msgs/CompressedImage (jpeg, png), decoded to rgb8 and resized
// (OpenCV INTER_AREA) to size x size, the pixels network's input. Images are
// time-aligned as the observation topics (header stamps).
struct SpecImage {
  std::string name;  // names it in errors and reports (default: the topic)
  std::string topic;
  std::string type;  // kImageType or kCompressedImageType
  int size = 64;     // pixels: the network's image height and width
};

// The goal: a PoseStamped topic whose fields fill observation fields by name
// (the others are 0), a full observation (Float64MultiArray data, already
// in observation units), or an image (Image or CompressedImage, decoded as the
// spec's camera: pixels policies).
struct SpecGoal {
  std::string source = "pose";  // pose | observation | image
  std::string topic = "goal_pose";
  std::string type = kPoseStampedType;
  struct Part {
    std::string observation;  // the observation field it fills
    SpecField field;          // read from the goal message, scaled as that observation field
  };
  std::vector<Part> parts;  // source pose
};

struct SpecEpisodes {
  std::string split_by = "gap";  // gap | topic | bag
  double gap = 1.0;   // s: a pause this long in the first observation topic starts an episode
  std::string topic;  // split_by topic: every message on it starts an episode (e.g. goal_pose)
};

struct RobotSpec {
  std::string source;  // the file it was read from (errors name it)
  std::string name;    // e.g. pointmaze_base
  // namespace: relative topics resolve under it, as ROS resolves names ("": the
  // policy node's own namespace; in a recording, the one namespace that holds
  // every topic of the spec, topic_names.h). msspr_bag_info / msspr_train --ns override it.
  std::string ns;
  double control_rate = 10.0;  // Hz: the policy acts once per 1 / control_rate s
  // Time alignment: the observation at tick t takes, per topic, the latest
  // message stamped at or before t + tolerance; it is stale when older than
  // t - stale_after. The action at tick t is the latest command stamped before
  // t + 1 / control_rate - tolerance, stale the same way.
  double tolerance = 0.005;  // s
  double stale_after = 0.5;  // s
  std::vector<SpecField> observation;
  // Cameras (at most one): a spec with images serves and trains pixels
  // policies; its state fields are still sampled (they time the episodes and
  // are stored beside the images).
  std::vector<SpecImage> images;
  SpecGoal goal;
  // The command: a topic and type; its fields in the action's order. A field
  // may name its own topic and type (e.g. an end-effector twist plus a gripper
  // command): each command topic gets one message per step.
  std::string action_topic = "cmd_vel";
  std::string action_type = kTwistType;
  std::string action_stamp;  // header | receipt (as SpecField::stamp)
  std::vector<SpecField> action;
  struct CommandTopic {
    std::string topic, type, stamp;
    std::vector<int> fields;         // indices into action
    std::vector<int> action_offset;  // where each field's values start in the action
    int size = 0;
  };
  // The distinct command topics, the action's own topic first.
  std::vector<CommandTopic> CommandTopics() const;
  SpecEpisodes episodes;
  std::string text;  // the YAML text it was parsed from (stored in checkpoints)

  int obs_dim() const;
  int action_dim() const;
  // The distinct observation topics, in order of first use.
  std::vector<std::string> ObservationTopics() const;
};

// Reads and checks a spec file; throws RobotSpecError naming `path` (and the
// topic and field at fault) on an unknown key, a missing or bad value, an
// unsupported type or a field path the type does not have.
RobotSpec LoadRobotSpec(const std::string& path);
// The same from YAML text; `source` names it in errors.
RobotSpec ParseRobotSpec(const std::string& yaml, const std::string& source);

// "" when `a` and `b` assemble the same observation and action the same way;
// otherwise what differs first, naming the field ("observation field
// 'position' (topic odom): scale 1 vs 2"). Names, sources and comments do not count.
std::string CompareRobotSpecs(const RobotSpec& a, const RobotSpec& b);

// The numeric paths `f` reads, resolved against its type: ["pose.pose.position.x",
// "pose.pose.position.y"] for field pose.pose.position with components [x, y];
// "position" / "velocity" / "effort" / "points[0].positions" etc. once per joint
// (the joint is named in SpecField::joints); "data[3]" per array index.
// Throws RobotSpecError naming `source`, the topic and the field when the type
// has no such path.
std::vector<std::string> ResolveFieldPaths(const SpecField& f, const std::string& source);

// The checkpoint header key under which msspr_train stores the spec's text.
inline constexpr char kRobotSpecCheckpointKey[] = "robot_spec";

}  // namespace msspr::ros_bridge
