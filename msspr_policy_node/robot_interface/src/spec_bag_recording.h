// The decoded messages of a robot's recording, shared by spec_bag.cc (reading the
// bags) and spec_bag_episodes.cc (cutting them into episodes at the control ticks).
// Internal to msspr_robot_interface.
#pragma once

#include <ros/time.h>

#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/spec_bag.h"

namespace msspr::ros_bridge {

// The decoded messages of a recording: every bag of the reader, in time order,
// as `rosbag play a.bag b.bag` plays them.
struct SpecBagReader::Recording {
  explicit Recording(const RobotSpec& spec)
      : layout(spec),
        cmd_topics(spec.CommandTopics()),
        histories(layout.topics.size()),
        commands(cmd_topics.size()),
        images(spec.images.size()),
        tf_buffer(ros::Duration(60.0)) {}
  SpecLayout layout;
  std::vector<RobotSpec::CommandTopic> cmd_topics;
  std::vector<TopicHistory> histories, commands, images;  // per observation topic, command, camera
  std::vector<ros::Time> boundaries;                      // episode-topic messages
  // A vector goal's messages (stamp, or receipt when unstamped; full goal observations).
  std::vector<std::pair<ros::Time, std::vector<float>>> goals;
  std::vector<uint8_t> last_episode_message;  // its bytes (latched repeats)
  tf2::BufferCore tf_buffer;
  struct Bag {
    std::string path;
    ros::Time begin, end;  // the bag's first and last message
  };
  std::vector<Bag> bags;  // in time order
  std::string label;      // names the recording in episode problems
};

namespace spec_bag_internal {

// A stamp as seconds with 3 decimals, for messages.
inline std::string Stamp(const ros::Time& t) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << t.toSec();
  return s.str();
}

}  // namespace spec_bag_internal
}  // namespace msspr::ros_bridge
