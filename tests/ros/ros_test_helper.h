// Shared helper of the rostest scenarios: subscribes to the sim's topics, waits
// with timeouts, and reads the sim's diagnostics counters.
#pragma once

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Reset.h"

namespace msspr::testing {

// Calls the sim's `reset` service (task 1..5, or 0 random where the env has
// it) and returns its response; a missing service or a failed call fails the test.
inline msspr::Reset::Response CallReset(ros::NodeHandle& nh, int task, uint64_t seed) {
  ros::ServiceClient c = nh.serviceClient<msspr::Reset>("reset");
  EXPECT_TRUE(c.waitForExistence(ros::Duration(30.0)));
  msspr::Reset srv;
  srv.request.task_id = task;
  srv.request.seed = seed;
  EXPECT_TRUE(c.call(srv));
  return srv.response;
}

// Spins until pred() holds or timeout_s of wall time pass; returns pred().
inline bool WaitFor(const std::function<bool()>& pred, double timeout_s) {
  const auto end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && !pred() && ros::WallTime::now() < end) {
    ros::spinOnce();
    ros::WallDuration(0.001).sleep();
  }
  ros::spinOnce();
  return pred();
}

class RosTestHelper {
 public:
  RosTestHelper() {
    obs_sub_ = nh_.subscribe<msspr::Observation>("observation", 1000,
                                                 [this](const msspr::Observation::ConstPtr& o) {
                                                   latest_ = o;
                                                   ++observations_;
                                                 });
    diag_sub_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 10, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& d) {
          for (const auto& st : d->status) {
            for (const auto& kv : st.values) statuses_[st.name][kv.key] = kv.value;
            if (st.name.find("actions") != std::string::npos)
              for (const auto& kv : st.values) counters_[kv.key] = std::stoull(kv.value);
          }
        });
    action_pub_ = nh_.advertise<msspr::Action>("action", 100);
  }

  // Spins until pred() holds or timeout_s of wall time pass; returns pred().
  bool WaitFor(const std::function<bool()>& pred, double timeout_s) {
    return msspr::testing::WaitFor(pred, timeout_s);
  }

  // Waits until the sim's observation topic and action subscriber are connected.
  bool WaitForSim(double timeout_s = 30.0) {
    return WaitFor(
        [&] { return obs_sub_.getNumPublishers() > 0 && action_pub_.getNumSubscribers() > 0; },
        timeout_s);
  }

  void SendAction(uint32_t episode, uint32_t step, std::vector<float> a) {
    msspr::Action m;
    m.episode_id = episode;
    m.step = step;
    m.action = std::move(a);
    action_pub_.publish(m);
  }

  uint64_t Counter(const std::string& key) const {
    auto it = counters_.find(key);
    return it == counters_.end() ? 0 : it->second;
  }

  // Latest value of `key` in a diagnostics status whose name contains
  // `status_part` (e.g. "policy"), or "" when none was received yet.
  std::string DiagValue(const std::string& status_part, const std::string& key) const {
    for (const auto& [name, values] : statuses_) {
      if (name.find(status_part) == std::string::npos) continue;
      auto it = values.find(key);
      if (it != values.end()) return it->second;
    }
    return "";
  }
  // DiagValue as a number; NaN when missing or not a number.
  double DiagNumber(const std::string& status_part, const std::string& key) const {
    const std::string v = DiagValue(status_part, key);
    try {
      return v.empty() ? NAN : std::stod(v);
    } catch (const std::exception&) {
      return NAN;
    }
  }

  ros::NodeHandle& nh() { return nh_; }
  msspr::Observation::ConstPtr latest() const { return latest_; }
  uint64_t observations() const { return observations_; }

 private:
  ros::NodeHandle nh_;
  ros::Subscriber obs_sub_, diag_sub_;
  ros::Publisher action_pub_;
  msspr::Observation::ConstPtr latest_;
  uint64_t observations_ = 0;
  std::map<std::string, uint64_t> counters_;
  std::map<std::string, std::map<std::string, std::string>>
      statuses_;  // status name -> key -> value
};

// A live collection recorded by `rosbag record` (the dataset topics of
// namespace /msspr, plus `extra_topic` when not empty) into a bag under
// $ROS_LOG_DIR; the collection's sim starts once the recorder, the agent and
// the test's helper subscribe. Finish() waits for episode `episodes` - 1 to
// reach step `length` - 1, stops the recorder and returns whether it got there.
class LiveRecording {
 public:
  // Records msspr's own topics (observation, action, episode) and `extra_topic`.
  LiveRecording(const std::string& name, const std::string& extra_topic = "")
      : LiveRecording(name, NativeTopics(extra_topic)) {}
  // Records exactly `topics` (e.g. a robot's standard topics) into NAME_PID.bag.
  LiveRecording(const std::string& name, const std::vector<std::string>& topics) {
    const char* dir = std::getenv("ROS_LOG_DIR");
    bag_ = std::string(dir ? dir : "/tmp") + "/" + name + "_" + std::to_string(getpid()) + ".bag";
    pid_ = fork();
    if (pid_ == 0) {
      const std::string node = "__name:=" + name + "_recorder";
      std::vector<std::string> args = {"rosbag", "record", "-O", bag_};
      args.insert(args.end(), topics.begin(), topics.end());
      args.push_back(node);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execvp("rosbag", argv.data());
      _exit(127);
    }
  }
  bool Finish(RosTestHelper& h, int episodes, int length, double timeout_s = 120.0) {
    const bool done = h.WaitFor(
        [&] {
          return h.latest() && h.latest()->episode_id == static_cast<uint32_t>(episodes - 1) &&
                 h.latest()->step == static_cast<uint32_t>(length - 1);
        },
        timeout_s);
    Stop();
    return done;
  }
  // Stops the recorder (after a second for the last messages) and waits for the bag.
  void Stop() {
    ros::WallDuration(1.0).sleep();  // the last action reaches the recorder
    if (pid_ > 0) {
      kill(pid_, SIGINT);
      int status = 0;
      waitpid(pid_, &status, 0);
      // `rosbag record` (a Python wrapper) can exit before its recorder child has
      // closed the bag and renamed NAME.bag.active to NAME.bag (seen on a loaded
      // machine): wait for the rename.
      const std::string active = bag_ + ".active";
      for (int i = 0;
           i < 200 && (access(bag_.c_str(), F_OK) != 0 || access(active.c_str(), F_OK) == 0); ++i)
        ros::WallDuration(0.05).sleep();
      pid_ = -1;
    }
  }
  bool started() const { return pid_ > 0; }
  static std::vector<std::string> NativeTopics(const std::string& extra_topic) {
    std::vector<std::string> t = {"/msspr/observation", "/msspr/action", "/msspr/episode"};
    if (!extra_topic.empty()) t.push_back(extra_topic);
    return t;
  }
  const std::string& bag() const { return bag_; }
  // Removes the bag after a passing test; keeps it (and says where) otherwise.
  void Cleanup() const {
    if (::testing::Test::HasFailure())
      std::cerr << "live recording kept for inspection: " << bag_ << "\n";
    else
      std::remove(bag_.c_str());
  }

 private:
  std::string bag_;
  pid_t pid_ = -1;
};

}  // namespace msspr::testing
