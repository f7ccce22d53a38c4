// What a simulator node does with the actions it receives, what it counts of
// them, and their /diagnostics status: shared by msspr_sim_node's point maze
// (PointMazeSimNode) and cube-single (CubeSimNode), so that both behave and report alike.
#ifndef MSSPR_SIM_ROS_ACTION_COUNTERS_H_
#define MSSPR_SIM_ROS_ACTION_COUNTERS_H_

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <diagnostic_msgs/KeyValue.h>
#include <ros/console.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr_bridge/msg_conversion.h"

namespace msspr::ros_bridge {

struct ActionCounters {
  uint64_t steps = 0, episodes = 0, actions = 0;
  uint64_t rejected_wrong_length = 0, rejected_nonfinite = 0, clipped = 0;
  uint64_t stale = 0, ignored_paused = 0, ignored_after_end = 0, timeouts = 0, republished = 0;
};

// Where an action message goes, given the node's state.
enum class ActionUse {
  kDrop,    // rejected (wrong length, NaN or Inf) or ignored (paused, episode over, stale)
  kLatest,  // realtime stepping: the action to hold until the next tick
  kStep,    // lockstep: it answers the current observation, step now
};
struct ActionGate {
  bool paused = false;
  bool active = false;    // an episode is running
  bool realtime = false;  // stepping "realtime" (else lockstep)
  int64_t episode_id = -1;
  uint32_t step = 0;  // the current observation's step
};

// Checks `msg` (expected_size values) against `gate`, counts the outcome in
// `c`, and writes the action clipped to [-1, 1] into `action` unless dropped.
// Malformed actions are logged (throttled).
inline ActionUse CheckAction(const msspr::Action& msg, size_t expected_size, const ActionGate& gate,
                             ActionCounters* c, std::vector<double>* action) {
  ++c->actions;
  if (msg.action.size() != expected_size) {
    ++c->rejected_wrong_length;
    ROS_ERROR_STREAM_THROTTLE_NAMED(
        1.0, "msspr_sim",
        "rejected action with " << msg.action.size() << " values, expected " << expected_size);
    return ActionUse::kDrop;
  }
  if (!AllFinite(msg.action)) {
    ++c->rejected_nonfinite;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, "msspr_sim", "rejected action with NaN or Inf values");
    return ActionUse::kDrop;
  }
  action->resize(expected_size);
  bool clipped = false;
  for (size_t i = 0; i < expected_size; ++i) {
    const double v = msg.action[i];
    (*action)[i] = std::clamp(v, -1.0, 1.0);
    clipped = clipped || std::abs(v) > 1.0;
  }
  if (clipped) ++c->clipped;
  if (gate.paused) {
    ++c->ignored_paused;
    return ActionUse::kDrop;
  }
  if (!gate.active) {
    ++c->ignored_after_end;
    return ActionUse::kDrop;
  }
  if (gate.realtime) return ActionUse::kLatest;
  if (static_cast<int64_t>(msg.episode_id) != gate.episode_id || msg.step != gate.step) {
    ++c->stale;  // answers an observation that is no longer current
    return ActionUse::kDrop;
  }
  return ActionUse::kStep;
}

// "NODE: actions": WARN with the count when malformed actions were rejected,
// else OK; every counter as a key/value.
inline diagnostic_msgs::DiagnosticStatus ActionDiagnostics(const ActionCounters& c,
                                                           const std::string& node_name,
                                                           const std::string& hardware_id) {
  diagnostic_msgs::DiagnosticStatus st;
  st.name = node_name + ": actions";
  st.hardware_id = hardware_id;
  const uint64_t rejected = c.rejected_wrong_length + c.rejected_nonfinite;
  st.level = rejected > 0 ? diagnostic_msgs::DiagnosticStatus::WARN
                          : diagnostic_msgs::DiagnosticStatus::OK;
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
