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
#include <map>
#include <sstream>

#include <ros/ros.h>

#include "cli_args.h"
#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr_sim/custom_tasks.h"
#include "msspr_sim/eval_protocol.h"
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
  --plot FILE.png     trajectories drawn on the maze, 5 per task (default: none)
  --success-plot F    bar chart of success per task (PNG)
  --tasks-file YAML   custom tasks instead of the maze's five, e.g.
                        tasks:
                          - {id: 1, start: [0.0, 0.0], goal: [8.0, 0.0]}
                      (start/goal in metres; sent through reset + set_goal; msspr_make_tasks
                      draws random ones)
  --step-timeout S    seconds without a new observation before an episode counts as stalled (default 10)
)";

struct EpisodeResult {
  bool success = false, stalled = false;
  int steps = 0;
  std::vector<Eigen::Vector2d> path;
  Eigen::Vector2d start, goal;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_eval", ros::init_options::AnonymousName);
  using msspr::ros_bridge::CliArgs;
  // Every flag is checked before anything else runs: a bad one is a usage error (exit 2).
  std::unique_ptr<CliArgs> args;
  std::unique_ptr<msspr::sim::MazeMap> map_ptr;
  std::string maze;
  std::vector<int> tasks;
  std::map<int, std::pair<std::vector<float>, std::vector<float>>> custom;  // id -> start, goal
  int episodes = 0, max_steps = 0;
  uint64_t seed = 0;
  double step_timeout = 0;
  try {
    args = std::make_unique<CliArgs>(argc, argv, std::set<std::string>{"help"},
                                     std::set<std::string>{"maze", "tasks", "episodes", "max-steps", "seed",
                                                           "agent", "out", "plot", "success-plot", "step-timeout",
                                                           "tasks-file"});
    if (args->Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args->positional().empty()) throw std::invalid_argument("unexpected argument '" + args->positional()[0] + "'");
    maze = args->Get("maze", "medium");
    map_ptr = std::make_unique<msspr::sim::MazeMap>(msspr::sim::MazeMap::FromName(maze));
    if (args->Has("tasks-file")) {
      for (const auto& t : msspr::sim::LoadCustomTasks(args->Get("tasks-file", ""), map_ptr.get())) {
        custom[t.id] = {{static_cast<float>(t.start.x()), static_cast<float>(t.start.y())},
                        {static_cast<float>(t.goal.x()), static_cast<float>(t.goal.y())}};
        tasks.push_back(t.id);
      }
    } else {
      for (long id : args->GetIntList("tasks", "1,2,3,4,5", 1, static_cast<long>(map_ptr->Tasks().size())))
        tasks.push_back(static_cast<int>(id));
    }
    episodes = static_cast<int>(args->GetInt("episodes", 50, 1, 1000000));
    max_steps = static_cast<int>(args->GetInt("max-steps", 1000, 1, 100000000));
    seed = static_cast<uint64_t>(args->GetInt("seed", 0, 0));
    step_timeout = args->GetDouble("step-timeout", 10.0, 1e-3, 1e6);
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval: " << e.what() << "\n" << kUsage;
    return 2;
  }
  const msspr::sim::MazeMap& map = *map_ptr;

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
      srv.request.seed = msspr::sim::EvalEpisodeSeed(seed, tasks[ti], e);
      if (custom.count(tasks[ti])) {
        srv.request.start = custom[tasks[ti]].first;
        srv.request.goal = custom[tasks[ti]].second;
      }
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

  msspr::sim::EvalReport report;
  report.env = "pointmaze-" + maze;
  report.agent = args->Get("agent", "agent");
  report.episodes_per_task = episodes;
  report.max_steps = max_steps;
  report.seed = seed;
  report.wall_time_s = wall;
  for (size_t ti = 0; ti < tasks.size(); ++ti) {
    msspr::sim::TaskResult t;
    t.task_id = tasks[ti];
    t.episodes = static_cast<int>(results[ti].size());
    int ok = 0;
    double steps = 0;
    for (auto& r : results[ti]) {
      ok += r.success;
      report.stalled_episodes += r.stalled;
      if (r.success) steps += r.steps;
    }
    t.success = t.episodes ? double(ok) / t.episodes : 0.0;
    t.mean_steps_successful = ok ? steps / ok : 0.0;
    if (custom.count(t.task_id)) {
      t.start.assign(custom[t.task_id].first.begin(), custom[t.task_id].first.end());
      t.goal.assign(custom[t.task_id].second.begin(), custom[t.task_id].second.end());
    }
    report.tasks.push_back(t);
  }
  msspr::sim::FinalizeReport(&report);
  std::cout << msspr::sim::EvalReportTable(map, report) << std::flush;
  try {
    if (args->Has("out")) {
      msspr::sim::WriteTextFile(args->Get("out", ""), msspr::sim::EvalReportJson(map, report));
      std::cout << "  results: " << args->Get("out", "") << "\n";
    }
    if (args->Has("success-plot")) {
      msspr::sim::SaveSuccessPlot(report, args->Get("success-plot", ""));
      std::cout << "  success per task: " << args->Get("success-plot", "") << "\n";
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
      msspr::sim::SaveTrajectoryPlot(map, paths, sg, ok, png);
      std::cout << "  picture: " << png << "\n";
    }
  } catch (const std::exception& e) {
    std::cout << std::flush;
    ROS_FATAL("msspr_eval: %s", e.what());
    return 1;
  }
  std::cout << std::flush;
  return 0;
}
