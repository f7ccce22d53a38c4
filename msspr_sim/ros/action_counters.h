// What a simulator node counts of the actions it receives, and their
// /diagnostics status: shared by msspr_sim_node's point maze (SimNode) and
// cube-single (CubeSimNode), so that both report alike.
#ifndef MSSPR_SIM_ROS_ACTION_COUNTERS_H_
#define MSSPR_SIM_ROS_ACTION_COUNTERS_H_

#include <cstdint>
#include <string>

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <diagnostic_msgs/KeyValue.h>

namespace msspr::ros_bridge {

struct ActionCounters {
  uint64_t steps = 0, episodes = 0, actions = 0;
  uint64_t rejected_wrong_length = 0, rejected_nonfinite = 0, clipped = 0;
  uint64_t stale = 0, ignored_paused = 0, ignored_after_end = 0, timeouts = 0, republished = 0;
};

// "NODE: actions": WARN with the count when malformed actions were rejected,
// else OK; every counter as a key/value.
inline diagnostic_msgs::DiagnosticStatus ActionDiagnostics(const ActionCounters& c, const std::string& node_name,
                                                           const std::string& hardware_id) {
  diagnostic_msgs::DiagnosticStatus st;
  st.name = node_name + ": actions";
  st.hardware_id = hardware_id;
  const uint64_t rejected = c.rejected_wrong_length + c.rejected_nonfinite;
  st.level = rejected > 0 ? diagnostic_msgs::DiagnosticStatus::WARN : diagnostic_msgs::DiagnosticStatus::OK;
  st.message = rejected > 0 ? std::to_string(rejected) + " malformed actions rejected" : "ok";
  auto kv = [&st](const std::string& k, uint64_t v) {
    diagnostic_msgs::KeyValue p;
    p.key = k;
    p.value = std::to_string(v);
    st.values.push_back(p);
  };
  kv("steps", c.steps);
  kv("episodes", c.episodes);
  kv("actions", c.actions);
  kv("rejected_wrong_length", c.rejected_wrong_length);
  kv("rejected_nonfinite", c.rejected_nonfinite);
  kv("clipped", c.clipped);
  kv("stale", c.stale);
  kv("ignored_paused", c.ignored_paused);
  kv("ignored_after_end", c.ignored_after_end);
  kv("timeouts", c.timeouts);
  kv("republished", c.republished);
  return st;
}

}  // namespace msspr::ros_bridge

#endif  // MSSPR_SIM_ROS_ACTION_COUNTERS_H_
