// msspr_bench_policy: measures a running msspr_policy_node (lockstep mode)
// from outside: the observation -> action latency over ROS (p50/p99, one
// observation in flight), then the highest observation rate it sustains
// (>= 99% answered, p99 under --max-p99-ms) when observations are sent at
// increasing fixed rates. State or pixels input, as the node's
// ~observation_mode says (or --pixels). Writes JSON to --out.
//
//   rosrun msspr msspr_bench_policy __ns:=msspr --node policy --out policy_state.json
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr_bridge/cli_args.h"
#include "msspr_bridge/msg_conversion.h"

namespace {

struct Stats {
  double p50 = NAN, p90 = NAN, p99 = NAN, max = NAN, mean = NAN;
};

Stats Summarise(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))]; };
  s.p50 = at(0.50);
  s.p90 = at(0.90);
  s.p99 = at(0.99);
  s.max = v.back();
  s.mean = 0;
  for (double x : v) s.mean += x / v.size();
  return s;
}

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char b[64];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

class Bench {
 public:
  Bench(bool pixels, int obs_dim, int image_size)
      : pixels_(pixels), obs_dim_(obs_dim), image_size_(image_size) {
    sub_ = nh_.subscribe<msspr::Action>(
        "action", 1000,
        [this](const msspr::Action::ConstPtr& a) {
          const auto it = sent_.find(Key(a->episode_id, a->step));
          if (it != sent_.end() && !answered_.count(it->first)) {
            answered_[it->first] = (ros::WallTime::now() - it->second).toSec() * 1e6;
          }
        },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    obs_pub_ = nh_.advertise<msspr::Observation>("observation", 100);
    if (pixels_) {
      image_pub_ = nh_.advertise<sensor_msgs::Image>("camera/image", 100);
      goal_pub_ = nh_.advertise<sensor_msgs::Image>("goal_image", 1, /*latch=*/true);
      frames_.resize(8);
      std::mt19937 rng(1);
      for (auto& f : frames_) {
        f.resize(static_cast<size_t>(image_size_) * image_size_ * 3);
        for (auto& b : f) b = static_cast<uint8_t>(rng() & 0xff);
      }
    }
  }

  // Waits until the node subscribes to the observations (and images) and publishes actions.
  bool Connect(double timeout_s) {
    const auto end = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < end) {
      const bool ok =
          obs_pub_.getNumSubscribers() > 0 && sub_.getNumPublishers() > 0 &&
          (!pixels_ || (image_pub_.getNumSubscribers() > 0 && goal_pub_.getNumSubscribers() > 0));
      if (ok) {
        if (pixels_)
          goal_pub_.publish(msspr::ros_bridge::ToImageMsg(frames_[0].data(), image_size_,
                                                          ros::Time(0.1), "camera"));
        ros::WallDuration(0.5).sleep();  // let the first messages of new connections through
        return true;
      }
      ros::WallDuration(0.01).sleep();
    }
    return false;
  }

  void Send(uint32_t episode, uint32_t step) {
    const ros::Time stamp(1.0 + 0.001 * (episode * 100000.0 + step));
    msspr::Observation o;
    o.header.stamp = stamp;
    o.header.frame_id = "world";
    o.episode_id = episode;
    o.step = step;
    o.state.assign(static_cast<size_t>(obs_dim_), 0.f);
    for (int i = 0; i < obs_dim_; ++i)
      o.state[i] = 0.01f * static_cast<float>((step + 7 * i) % 100);
    o.goal.assign(static_cast<size_t>(obs_dim_), 4.f);
    sent_[Key(episode, step)] = ros::WallTime::now();
    if (pixels_)
      image_pub_.publish(msspr::ros_bridge::ToImageMsg(frames_[step % frames_.size()].data(),
                                                       image_size_, stamp, "camera"));
    obs_pub_.publish(o);
  }

  // Processes callbacks for up to `s` seconds (returns early when one arrives).
  void Spin(double s) {
    ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(std::max(0.0, s)));
  }

  bool Answered(uint32_t episode, uint32_t step) const {
    return answered_.count(Key(episode, step)) > 0;
  }
  double LatencyUs(uint32_t episode, uint32_t step) const {
    return answered_.at(Key(episode, step));
  }
  std::vector<double> Latencies(uint32_t episode) const {
    std::vector<double> v;
    for (const auto& [k, us] : answered_)
      if ((k >> 32) == episode) v.push_back(us);
    return v;
  }

 private:
  static uint64_t Key(uint32_t episode, uint32_t step) { return (uint64_t{episode} << 32) | step; }

  bool pixels_;
  int obs_dim_, image_size_;
  ros::NodeHandle nh_;
  ros::Subscriber sub_;
  ros::Publisher obs_pub_, image_pub_, goal_pub_;
  std::vector<std::vector<uint8_t>> frames_;
  std::map<uint64_t, ros::WallTime> sent_;
  std::map<uint64_t, double> answered_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_bench_policy", ros::init_options::AnonymousName);
  try {
    msspr::ros_bridge::CliArgs args(
        argc, argv, {"pixels"},
        {"node", "samples", "warmup", "out", "label", "obs-dim", "image-size", "rates",
         "rate-seconds", "max-p99-ms", "timeout"});
    // Flags first (a bad one: exit 2 before any ROS traffic).
    const int samples = static_cast<int>(args.GetInt("samples", 2000, 1, 100000000));
    const int warmup = static_cast<int>(args.GetInt("warmup", 100, 0, 100000000));
    const double rate_seconds = args.GetDouble("rate-seconds", 2.0, 0.01, 1e6);
    const double max_p99_ms = args.GetDouble("max-p99-ms", 50.0, 0.0, 1e9);
    const double timeout = args.GetDouble("timeout", 5.0, 0.001, 1e6);
    const int obs_dim = static_cast<int>(args.GetInt("obs-dim", 2, 1, 1 << 20));
    const int image_size = static_cast<int>(args.GetInt("image-size", 64, 1, 4096));
    std::vector<double> rates;
    {
      std::stringstream ss(args.Get("rates", "50,100,200,400,800,1600,3200"));
      for (std::string r; std::getline(ss, r, ',');)
        rates.push_back(msspr::cli::ParseDouble("rates", r, 1e-3, 1e7));
    }
    ros::NodeHandle nh;
    const std::string node = args.Get("node", "policy");
    std::string mode = "state";
    nh.param<std::string>(node + "/observation_mode", mode, "state");
    const bool pixels = args.Has("pixels") || mode == "pixels";

    Bench bench(pixels, obs_dim, image_size);
    if (!bench.Connect(30.0)) {
      std::fprintf(stderr,
                   "msspr_bench_policy: no policy node on %s (observation / action) within 30 s\n",
                   ros::this_node::getNamespace().c_str());
      return 1;
    }

    // 1. One observation in flight: latency.
    const uint32_t kLatencyEpisode = 1;
    const ros::WallTime t_start = ros::WallTime::now();
    std::vector<double> us;
    for (int k = 0; k < warmup + samples && ros::ok(); ++k) {
      const auto step = static_cast<uint32_t>(k);
      const ros::WallTime t0 = ros::WallTime::now();
      bench.Send(kLatencyEpisode, step);
      while (ros::ok() && !bench.Answered(kLatencyEpisode, step)) {
        if ((ros::WallTime::now() - t0).toSec() > timeout) {
          std::fprintf(stderr, "msspr_bench_policy: no action for step %u within %.1f s\n", step,
                       timeout);
          return 1;
        }
        bench.Spin(0.005);
      }
      if (k >= warmup) us.push_back(bench.LatencyUs(kLatencyEpisode, step));
    }
    const double closed_loop_hz = (warmup + samples) / (ros::WallTime::now() - t_start).toSec();
    const Stats lat = Summarise(us);

    // 2. Fixed send rates, increasing, until one is not sustained.
    std::string rate_rows;
    double max_sustained = 0;
    for (size_t i = 0; i < rates.size() && ros::ok(); ++i) {
      const auto episode = static_cast<uint32_t>(100 + i);
      const int n = std::max(1, static_cast<int>(rates[i] * rate_seconds));
      const ros::WallTime begin = ros::WallTime::now();
      for (int k = 0; k < n && ros::ok(); ++k) {
        const ros::WallTime due = begin + ros::WallDuration(k / rates[i]);
        while (ros::WallTime::now() < due) bench.Spin((due - ros::WallTime::now()).toSec());
        bench.Send(episode, static_cast<uint32_t>(k));
      }
      const ros::WallTime sent_end = ros::WallTime::now();
      const ros::WallTime drain = sent_end + ros::WallDuration(0.5);
      while (ros::ok() && ros::WallTime::now() < drain) bench.Spin(0.01);
      const std::vector<double> v = bench.Latencies(episode);
      const Stats s = Summarise(v);
      const double answered = static_cast<double>(v.size()) / n;
      const double achieved = v.size() / std::max(1e-9, (sent_end - begin).toSec());
      const bool ok = answered >= 0.99 && s.p99 <= max_p99_ms * 1e3;
      char row[256];
      std::snprintf(
          row, sizeof row,
          "%s{\"target_hz\": %.0f, \"achieved_hz\": %.1f, \"answered\": %.4f, \"p50_us\": %s, "
          "\"p99_us\": %s, \"sustained\": %s}",
          rate_rows.empty() ? "" : ", ", rates[i], achieved, answered, Num(s.p50).c_str(),
          Num(s.p99).c_str(), ok ? "true" : "false");
      rate_rows += row;
      std::fprintf(stderr, "rate %.0f Hz: answered %.1f%%, p50 %s us, p99 %s us%s\n", rates[i],
                   100 * answered, Num(s.p50).c_str(), Num(s.p99).c_str(),
                   ok ? "" : " (not sustained)");
      if (!ok) break;
      max_sustained = rates[i];
    }

    std::ostringstream json;
    json << "{\"policy_latency_us\": {\"label\": \""
         << args.Get("label", pixels ? "pixels" : "state") << "\", \"observation_mode\": \""
         << (pixels ? "pixels" : "state") << "\", \"samples\": " << us.size()
         << ", \"p50\": " << Num(lat.p50) << ", \"p90\": " << Num(lat.p90)
         << ", \"p99\": " << Num(lat.p99) << ", \"max\": " << Num(lat.max)
         << ", \"mean\": " << Num(lat.mean) << ", \"closed_loop_hz\": " << Num(closed_loop_hz)
         << ", \"max_sustained_hz\": " << Num(max_sustained) << ", \"max_p99_ms\": " << max_p99_ms
         << ", \"rates\": [" << rate_rows << "]}}\n";
    std::printf("%s", json.str().c_str());
    if (args.Has("out")) {
      std::ofstream f(args.Get("out", ""));
      f << json.str();
      if (!f) {
        std::fprintf(stderr, "msspr_bench_policy: cannot write %s\n", args.Get("out", "").c_str());
        return 1;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_bench_policy: %s\n", e.what());
    return 2;
  }
  return 0;
}
