// A spec's topic names resolved against the topics of a recording, as ROS
// resolves names: an absolute name ("/odom") is itself; a relative one ("odom",
// "gripper/joint_states") lives in a namespace. The namespace is the one given
// (msspr_bag_info --ns, msspr_train --ns, or the spec's `namespace:` key), or,
// when none is, the one namespace of the recording that holds every relative
// topic of the spec: the root when it does, else the namespace under which they
// all were recorded (a robot under /msspr publishes /msspr/joint_states and
// /msspr/gripper/joint_states, and `joint_states` resolves to the first: a topic
// is matched as a whole name under a namespace, never by its last segment alone;
// of two namespaces that both hold the spec, one inside the other, the outer wins).
// No ROS header.
#pragma once

#include <set>
#include <string>
#include <vector>

namespace msspr::ros_bridge {

// "/" + ns + "/" + name, with the slashes made single; an absolute name is
// returned as is. NormalizeNamespace("msspr/") == "/msspr"; the root is "/".
std::string NormalizeNamespace(const std::string& ns);
std::string ResolveTopicName(const std::string& ns, const std::string& name);

struct TopicResolution {
  std::string ns;                   // the namespace used ("/" for the root)
  bool inferred = false;            // found in the recording, not given
  std::vector<std::string> topics;  // the bag topic of each spec topic, in order
};

// Resolves `names` (a spec's topics) against `bag_topics`. Throws
// std::invalid_argument, saying which names are missing under which namespace
// and which namespaces were candidates, when a name does not resolve to a topic
// of the recording, or when several namespaces hold every relative name (then
// one must be given).
TopicResolution ResolveSpecTopics(const std::vector<std::string>& names,
                                  const std::set<std::string>& bag_topics, const std::string& ns);

}  // namespace msspr::ros_bridge
