// msspr_bench_lockstep: measures the lockstep round trip over ROS (action
// published -> next observation received) against a running msspr_sim_node,
// and writes p50/p99 in microseconds as JSON.
#include <ros/ros.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <memory>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr_bridge/cli_args.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_bench_lockstep", ros::init_options::AnonymousName);
  std::unique_ptr<msspr::ros_bridge::CliArgs> parsed;
  int steps = 0;
  try {
    parsed = std::make_unique<msspr::ros_bridge::CliArgs>(
        argc, argv, std::set<std::string>{"help"}, std::set<std::string>{"steps", "out", "label"});
    steps = static_cast<int>(parsed->GetInt("steps", 5000, 1, 100000000));
    if (parsed->Has("help")) {
      std::printf("usage: msspr_bench_lockstep [--steps N] [--out FILE.json] [--label NAME]\n");
      return 0;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_bench_lockstep: %s\n", e.what());
    return 2;
  }
  const auto& args = *parsed;
  ros::NodeHandle nh;
  msspr::Observation::ConstPtr latest;
  auto sub = nh.subscribe<msspr::Observation>(
      "observation", 10, [&](const msspr::Observation::ConstPtr& o) { latest = o; },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  auto pub = nh.advertise<msspr::Action>("action", 10);
  auto reset = nh.serviceClient<msspr::Reset>("reset");
  if (!reset.waitForExistence(ros::Duration(30))) {
    std::fprintf(stderr, "msspr_bench_lockstep: no reset service\n");
    return 1;
  }
  while (ros::ok() && (sub.getNumPublishers() == 0 || pub.getNumSubscribers() == 0))
    ros::WallDuration(0.01).sleep();
  ros::WallDuration(0.3).sleep();
  std::vector<double> us;
  us.reserve(steps);
  msspr::Reset r;
  r.request.task_id = 1;
  int done = 0;
  while (ros::ok() && done < steps) {
    r.request.seed = static_cast<uint64_t>(done);
    if (!reset.call(r) || !r.response.ok) return 1;
    uint32_t id = r.response.observation.episode_id, step = 0;
    for (int k = 0; k < 900 && done < steps; ++k, ++done) {
      msspr::Action a;
      a.episode_id = id;
      a.step = step;
      a.action = {0.3f, -0.2f};
      const auto t0 = ros::WallTime::now();
      pub.publish(a);
      while (ros::ok()) {
        ros::spinOnce();
        if (latest && latest->episode_id == id && latest->step == step + 1) break;
        if ((ros::WallTime::now() - t0).toSec() > 5.0) {
          std::fprintf(stderr, "msspr_bench_lockstep: no observation within 5 s\n");
          return 1;
        }
      }
      us.push_back((ros::WallTime::now() - t0).toSec() * 1e6);
      ++step;
    }
  }
  std::sort(us.begin(), us.end());
  const double p50 = us[us.size() / 2], p99 = us[std::min(us.size() - 1, us.size() * 99 / 100)];
  double mean = 0;
  for (double v : us) mean += v / us.size();
  char json[512];
  std::snprintf(json, sizeof json,
                "{\"lockstep_round_trip_us\": {\"label\": \"%s\", \"steps\": %zu, \"p50\": %.1f, "
                "\"p99\": %.1f, "
                "\"mean\": %.1f, \"steps_per_s\": %.1f}}\n",
                args.Get("label", "state").c_str(), us.size(), p50, p99, mean, 1e6 / mean);
  std::printf("%s", json);
  if (args.Has("out")) std::ofstream(args.Get("out", "")) << json;
  return 0;
}
