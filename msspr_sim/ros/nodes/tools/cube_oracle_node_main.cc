// msspr_cube_oracle_node: the cube-single play oracle over ROS (CubeGoalOracle):
// answers each observation of msspr_sim_node (~env cube-single) with the
// oracle's action, in lockstep. ~mode goal (default): toward the
// observation's goal, noise off; the agent that msspr_eval --env cube-single
// and the oracle rostest drive. ~mode play: OGBench's play
// oracle (random targets, noise 0.1), the agent of a live collection
// (launch/collect.launch env:=cube-single, the sim in collection mode).
// ~command action (default): msspr/Action on action; standard: the arm's
// standard commands, as config/robots/ur5e_cube.yaml reads them, a
// geometry_msgs/TwistStamped on ee_twist (kCubeEeSpeed, kCubeEeYawRate) and a
// std_msgs/Float64MultiArray on gripper_command (collect.launch robot:=ur5e_cube).
#include <geometry_msgs/TwistStamped.h>
#include <ros/ros.h>
#include <std_msgs/Float64MultiArray.h>

#include <cmath>
#include <memory>
#include <stdexcept>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim_nodes/cube_goal_oracle.h"
#include "msspr_sim_nodes/cube_sim_node.h"

namespace {

class CubeOracleNode {
 public:
  CubeOracleNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh) {
    std::string urdf = msspr::sim::DefaultArmUrdf();
    pnh.param<std::string>("urdf", urdf, urdf);
    std::string mode = "goal";
    pnh.param<std::string>("mode", mode, mode);
    if (mode != "goal" && mode != "play")
      throw std::invalid_argument("~mode must be goal or play, got '" + mode + "'");
    play_ = mode == "play";
    double noise = play_ ? msspr::sim::CubePlayOracleOptions().noise_scale : 0.0;
    pnh.param("noise_scale", noise, noise);
    if (!(noise >= 0 && std::isfinite(noise)))
      throw std::invalid_argument("~noise_scale must be >= 0");
    pnh.param("seed", seed_, 0);
    std::string command = "action";
    pnh.param<std::string>("command", command, command);
    if (command != "action" && command != "standard")
      throw std::invalid_argument("~command must be action or standard, got '" + command + "'");
    standard_ = command == "standard";
    int wait = 0;
    pnh.param("wait_for_command_subscribers", wait, wait);
    wait_ = msspr::ros_bridge::CommandSubscriberWait(wait);
    ROS_INFO_STREAM("msspr_cube_oracle_node parameters:\n  urdf: "
                    << urdf << "\n  mode: " << mode << "\n  noise_scale: " << noise
                    << "\n  seed: " << seed_ << "\n  command: " << command
                    << "\n  wait_for_command_subscribers: " << wait);
    auto opt = msspr::ros_bridge::CubeGoalOracle::NoNoise();
    opt.noise_scale = noise;
    oracle_ = std::make_unique<msspr::ros_bridge::CubeGoalOracle>(
        urdf, static_cast<uint64_t>(seed_), opt);
    if (standard_) {
      twist_pub_ = nh_.advertise<geometry_msgs::TwistStamped>("ee_twist", 10);
      grip_pub_ = nh_.advertise<std_msgs::Float64MultiArray>("gripper_command", 10);
    } else {
      action_pub_ = nh_.advertise<msspr::Action>("action", msspr::ros_bridge::kStepTopicQueue);
    }
    obs_sub_ = nh_.subscribe("observation", 10, &CubeOracleNode::OnObservation, this,
                             ros::TransportHints().tcpNoDelay());
  }

 private:
  void OnObservation(const msspr::Observation::ConstPtr& obs) {
    if (obs->state.size() != 28 || (!play_ && obs->goal.size() != 28) ||
        !msspr::ros_bridge::AllFinite(obs->state) || !msspr::ros_bridge::AllFinite(obs->goal)) {
      ROS_ERROR_THROTTLE(
          1.0,
          "msspr_cube_oracle_node: ignoring an observation that is not cube-single's "
          "(28-D state%s)",
          play_ ? "" : " and goal");
      return;
    }
    // Goal mode: the episode is over. Play mode: the last step's action is
    // recorded too (the collection's next reset follows it).
    if (!play_ && (obs->last || obs->success)) return;
    if (!(standard_ ? wait_.Ready({&twist_pub_, &grip_pub_}, "msspr_cube_oracle_node")
                    : wait_.Ready({&action_pub_}, "msspr_cube_oracle_node")))
      return;
    if (static_cast<int64_t>(obs->episode_id) != episode_) {  // a new episode: a fresh plan
      episode_ = obs->episode_id;
      step_ = -1;
      oracle_->Reset(static_cast<uint64_t>(seed_) * 1000003u + obs->episode_id);
    }
    // A re-sent observation (the sim's republish: the answer was lost) gets the same action.
    if (static_cast<int64_t>(obs->step) != step_) {
      step_ = obs->step;
      last_ = play_ ? oracle_->ActPlay(obs->state.data())
                    : oracle_->Act(obs->state.data(), obs->goal.data());
    }
    const auto& a = last_;
    if (standard_) {  // the command for this observation's step, stamped with its time
      geometry_msgs::TwistStamped t;
      t.header.stamp = obs->header.stamp;
      t.twist.linear.x = a[0] * msspr::ros_bridge::kCubeEeSpeed;
      t.twist.linear.y = a[1] * msspr::ros_bridge::kCubeEeSpeed;
      t.twist.linear.z = a[2] * msspr::ros_bridge::kCubeEeSpeed;
      t.twist.angular.z = a[3] * msspr::ros_bridge::kCubeEeYawRate;
      std_msgs::Float64MultiArray g;
      g.data = {a[4]};
      grip_pub_.publish(g);
      twist_pub_.publish(t);
      return;
    }
    msspr::Action m;
    m.header.stamp = obs->header.stamp;
    m.episode_id = obs->episode_id;
    m.step = obs->step;
    m.action.assign(a.begin(), a.end());
    action_pub_.publish(m);
  }

  ros::NodeHandle nh_;
  ros::Publisher action_pub_, twist_pub_, grip_pub_;
  ros::Subscriber obs_sub_;
  msspr::ros_bridge::CommandSubscriberWait wait_;
  std::unique_ptr<msspr::ros_bridge::CubeGoalOracle> oracle_;
  int seed_ = 0;
  bool play_ = false, standard_ = false;
  int64_t episode_ = -1, step_ = -1;
  msspr::sim::CubeEnv::Action last_{};
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_cube_oracle_node");
  ros::NodeHandle nh, pnh("~");
  try {
    CubeOracleNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_cube_oracle_node: " << e.what());
    return 1;
  }
  return 0;
}
