// msspr_eval: OGBench's evaluation protocol over ROS. For each task it resets the
// sim (reset service) and follows the observations that the agent under test (the
// expert node or msspr_policy_node, in lockstep) drives, until success or the step
// limit. Prints a per-task table; writes a results JSON and a trajectory PNG.
#include <sys/stat.h>

#include <chrono>
#include <deque>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <ros/ros.h>

#include "cli_args.h"
#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/maze_plot.h"

namespace {

constexpr char kUsage[] = R"(usage: rosrun msspr msspr_eval [options]
Evaluates the agent that answers the sim's observations (lockstep), by OGBench's protocol.
  --maze NAME         maze of the running sim (default medium)
  --tasks LIST        comma-separated task ids (default 1,2,3,4,5)
  --episodes N        episodes per task (default 50)
  --max-steps N       step limit per episode (default 1000)
  --seed S            evaluation seed (default 0)
  --agent NAME        label written into the results (default "agent")
  --out FILE.json     results JSON (default: none)
  --plot FILE.png     trajectories drawn on the maze (default: none)
  --step-timeout S    seconds without a new observation before an episode counts as stalled (default 10)
)";

struct EpisodeResult {
  bool success = false, stalled = false;
  int steps = 0;
  std::vector<Eigen::Vector2d> path;
  Eigen::Vector2d start, goal;
};

std::string Dir(const std::string& path) {
  const auto p = path.find_last_of('/');
  return p == std::string::npos ? "" : path.substr(0, p);
}

void MakeDirs(const std::string& dir) {
  if (dir.empty()) return;
  std::string cur;
  std::stringstream ss(dir);
  std::string part;
  if (dir[0] == '/') cur = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    cur += part + "/";
    mkdir(cur.c_str(), 0755);
  }
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_eval", ros::init_options::AnonymousName);
  using msspr::ros_bridge::CliArgs;
  std::unique_ptr<CliArgs> args;
  try {
    args = std::make_unique<CliArgs>(argc, argv, std::set<std::string>{"help"},
                                     std::set<std::string>{"maze", "tasks", "episodes", "max-steps", "seed",
                                                           "agent", "out", "plot", "step-timeout"});
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval: " << e.what() << "\n" << kUsage;
    return 2;
  }
  if (args->Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  const std::string maze = args->Get("maze", "medium");
  const auto map = msspr::sim::MazeMap::FromName(maze);
  std::vector<int> tasks;
  {
    std::stringstream ss(args->Get("tasks", "1,2,3,4,5"));
    std::string t;
    while (std::getline(ss, t, ',')) tasks.push_back(std::stoi(t));
  }
  const int episodes = static_cast<int>(args->GetInt("episodes", 50));
  const int max_steps = static_cast<int>(args->GetInt("max-steps", 1000));
  const uint64_t seed = static_cast<uint64_t>(args->GetInt("seed", 0));
  const double step_timeout = args->GetDouble("step-timeout", 10.0);

  ros::NodeHandle nh;
  std::deque<msspr::Observation::ConstPtr> inbox;  // every observation, in order
  ros::Subscriber sub = nh.subscribe<msspr::Observation>(
      "observation", 1000, [&](const msspr::Observation::ConstPtr& o) { inbox.push_back(o); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ros::ServiceClient reset = nh.serviceClient<msspr::Reset>("reset");
  ROS_INFO("msspr_eval: waiting for the sim's reset service %s", reset.getService().c_str());
  if (!reset.waitForExistence(ros::Duration(60.0))) {
    ROS_FATAL("msspr_eval: no reset service after 60 s (is msspr_sim_node running?)");
    return 1;
  }
  const auto wall0 = std::chrono::steady_clock::now();
  while (ros::ok() && sub.getNumPublishers() == 0) ros::WallDuration(0.05).sleep(), ros::spinOnce();
  ros::WallDuration(0.5).sleep();  // let the agent connect too

  std::vector<std::vector<EpisodeResult>> results(tasks.size());
  for (size_t ti = 0; ti < tasks.size() && ros::ok(); ++ti) {
    for (int e = 0; e < episodes && ros::ok(); ++e) {
      msspr::Reset srv;
      srv.request.task_id = tasks[ti];
      srv.request.seed = (
          msspr::sim::EpisodeSeed(seed, static_cast<uint64_t>(tasks[ti]) * 100000 + e));
      if (!reset.call(srv) || !srv.response.ok) {
        ROS_FATAL_STREAM("msspr_eval: reset of task " << tasks[ti] << " failed: " << srv.response.message);
        return 1;
      }
      const auto& first = srv.response.observation;
      EpisodeResult r;
      r.start = {first.state[0], first.state[1]};
      r.goal = {srv.response.goal[0], srv.response.goal[1]};
      r.path.push_back(r.start);
      const uint32_t id = first.episode_id;
      uint32_t last_step = 0;
      auto last_progress = ros::WallTime::now();
      bool finished = false;
      while (ros::ok() && !finished) {
        ros::spinOnce();
        if (inbox.empty()) {
          if ((ros::WallTime::now() - last_progress).toSec() > step_timeout) {
            r.stalled = true;
            ROS_WARN("msspr_eval: task %d episode %d stalled at step %u (no observation for %.0f s)",
                     tasks[ti], e, last_step, step_timeout);
            break;
          }
          ros::WallDuration(0.0002).sleep();
          continue;
        }
        while (!inbox.empty() && !finished) {
          const auto o = inbox.front();
          inbox.pop_front();
          if (o->episode_id != id || o->step <= last_step) continue;  // older episode or re-send
          last_step = o->step;
          r.path.emplace_back(o->state[0], o->state[1]);
          last_progress = ros::WallTime::now();
          if (o->success) {
            r.success = true;
            finished = true;
          } else if (static_cast<int>(o->step) >= max_steps || o->last) {
            finished = true;
          }
        }
      }
      r.steps = static_cast<int>(last_step);
      results[ti].push_back(std::move(r));
    }
    int ok = 0;
    for (auto& r : results[ti]) ok += r.success;
    ROS_INFO("msspr_eval: task %d done: %d/%zu", tasks[ti], ok, results[ti].size());
  }
  if (!ros::ok()) return 1;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();

  // Table and JSON.
  std::ostringstream table, json;
  table << "\n  task  start -> goal       success   mean steps (successful)\n";
  json << std::fixed << std::setprecision(4);
  json << "{\n  \"env\": \"pointmaze-" << maze << "\",\n  \"agent\": \"" << args->Get("agent", "agent")
       << "\",\n  \"episodes_per_task\": " << episodes << ",\n  \"max_steps\": " << max_steps
       << ",\n  \"seed\": " << seed << ",\n  \"tasks\": [\n";
  double mean = 0.0;
  int stalled = 0;
  for (size_t ti = 0; ti < tasks.size(); ++ti) {
    const auto& task = map.Tasks().at(static_cast<size_t>(tasks[ti] - 1));
    int ok = 0;
    double steps = 0;
    for (auto& r : results[ti]) {
      ok += r.success;
      stalled += r.stalled;
      if (r.success) steps += r.steps;
    }
    const double rate = results[ti].empty() ? 0.0 : double(ok) / results[ti].size();
    mean += rate / tasks.size();
    char line[160];
    std::snprintf(line, sizeof line, "  %4d  (%d,%d) -> (%d,%d)   %3d/%-3zu %5.1f%%   %.0f\n", tasks[ti],
                  task.start.i, task.start.j, task.goal.i, task.goal.j, ok, results[ti].size(),
                  100 * rate, ok ? steps / ok : 0.0);
    table << line;
    json << "    {\"task_id\": " << tasks[ti] << ", \"start_cell\": [" << task.start.i << ", "
         << task.start.j << "], \"goal_cell\": [" << task.goal.i << ", " << task.goal.j
         << "], \"success\": " << rate << ", \"episodes\": " << results[ti].size()
         << ", \"mean_steps_successful\": " << (ok ? steps / ok : 0.0) << "}"
         << (ti + 1 < tasks.size() ? "," : "") << "\n";
  }
  char line[120];
  std::snprintf(line, sizeof line, "  mean success: %.1f%%  (%d episodes, %.1f s)\n", 100 * mean,
                episodes * static_cast<int>(tasks.size()), wall);
  table << line;
  json << "  ],\n  \"mean_success\": " << mean << ",\n  \"stalled_episodes\": " << stalled
       << ",\n  \"wall_time_s\": " << wall << "\n}\n";
  std::cout << table.str() << std::flush;

  if (args->Has("out")) {
    const std::string out = args->Get("out", "");
    MakeDirs(Dir(out));
    std::ofstream f(out);
    f << json.str();
    if (!f) {
      ROS_FATAL("msspr_eval: cannot write %s", out.c_str());
      return 1;
    }
    std::cout << "  results: " << out << "\n";
  }
  if (args->Has("plot")) {
    std::vector<std::vector<Eigen::Vector2d>> paths;
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> sg;
    std::vector<bool> ok;
    for (auto& task_results : results)
      for (size_t k = 0; k < task_results.size() && k < 5; ++k) {  // 5 per task keeps it readable
        paths.push_back(task_results[k].path);
        sg.emplace_back(task_results[k].start, task_results[k].goal);
        ok.push_back(task_results[k].success);
      }
    const std::string png = args->Get("plot", "");
    MakeDirs(Dir(png));
    msspr::sim::SaveTrajectoryPlot(map, paths, sg, ok, png);
    std::cout << "  picture: " << png << "\n";
  }
  std::cout << std::flush;
  return 0;
}
