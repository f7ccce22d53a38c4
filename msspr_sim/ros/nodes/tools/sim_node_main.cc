#include <ros/ros.h>

#include <optional>

#include "msspr_sim/env_id.h"
#include "msspr_sim_nodes/ant_sim_node.h"
#include "msspr_sim_nodes/arm_task_sim_node.h"
#include "msspr_sim_nodes/cube_sim_node.h"
#include "msspr_sim_nodes/point_maze_sim_node.h"

// ~env picks the environment: pointmaze (default; ~maze picks the maze),
// cube-single (the URDF arm, cube_sim_node.h), puzzle-3x3 / puzzle-4x4, cube-double and scene
// (the arm and a button grid, two cubes, or a cube, buttons, drawer and window;
// arm_task_sim_node.h) or antmaze-medium / antmaze-large
// (the ant, ant_sim_node.h). All serve the same topics, messages and services.
int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_sim_node");
  ros::NodeHandle nh, pnh("~");
  try {
    using msspr::sim::EnvId;
    std::string env = msspr::sim::EnvIdName(EnvId::kPointMaze);
    pnh.param<std::string>("env", env, env);
    const std::optional<EnvId> id = msspr::sim::TryParseEnvId(env);
    if (id == EnvId::kCubeSingle) {
      const auto options = msspr::ros_bridge::LoadCubeSimNodeOptions(pnh);
      msspr::ros_bridge::CubeSimNode node(nh, pnh, options);
      ros::spin();
    } else if (id == EnvId::kPointMaze) {
      const auto options = msspr::ros_bridge::LoadPointMazeSimNodeOptions(pnh);
      msspr::ros_bridge::PointMazeSimNode node(nh, pnh, options);
      ros::spin();
    } else if (id && msspr::sim::IsPuzzle(*id)) {
      const auto options = msspr::ros_bridge::LoadArmTaskSimNodeOptions(pnh, *id);
      msspr::ros_bridge::PuzzleSimNode node(nh, pnh, options);
      ros::spin();
    } else if (id == EnvId::kCubeDouble) {
      const auto options = msspr::ros_bridge::LoadArmTaskSimNodeOptions(pnh, *id);
      msspr::ros_bridge::CubeDoubleSimNode node(nh, pnh, options);
      ros::spin();
    } else if (id == EnvId::kScene) {
      const auto options = msspr::ros_bridge::LoadArmTaskSimNodeOptions(pnh, *id);
      msspr::ros_bridge::SceneSimNode node(nh, pnh, options);
      ros::spin();
    } else if (id && msspr::sim::IsAntMaze(*id)) {
      const auto options = msspr::ros_bridge::LoadAntSimNodeOptions(pnh, *id);
      msspr::ros_bridge::AntSimNode node(nh, pnh, options);
      ros::spin();
    } else {
      throw std::invalid_argument(
          "~env must be pointmaze, cube-single, cube-double, scene, puzzle-3x3, puzzle-4x4, "
          "antmaze-medium or antmaze-large, got '" +
          env + "'");
    }
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_sim_node: " << e.what());
    return 1;
  }
  return 0;
}
