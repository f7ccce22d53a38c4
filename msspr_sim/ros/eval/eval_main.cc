// msspr_eval: OGBench's evaluation protocol over ROS. For each task it resets the
// sim (reset service) and follows the observations that the agent under test (the
// expert node or msspr_policy_node, in lockstep) drives, until success or the step
// limit. Prints a per-task table; writes a results JSON and a trajectory PNG.
// With --sims N it drives N sim + agent pairs in namespaces PREFIX0..PREFIX{N-1} at
// once: one thread per sim takes (task, episode) pairs from a shared queue, and the
// results are merged in the serial order (the JSON equals the serial run's but for
// wall_time_s).
#include <ros/callback_queue.h>
#include <ros/master.h>
#include <ros/names.h>
#include <ros/ros.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr_bridge/cli_args.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim/cube_failures.h"
#include "msspr_sim/custom_tasks.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/lights_out.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/maze_plot.h"

namespace {

constexpr char kUsage[] = R"(usage: rosrun msspr msspr_eval [options]
Evaluates the agent that answers the sim's observations (lockstep), by OGBench's protocol.
  --env ENV           pointmaze | cube-single | cube-double | scene | puzzle-3x3 | puzzle-4x4 |
                      antmaze-medium | antmaze-large: the running sim's env (default pointmaze)
  --maze NAME         maze of the running point-maze sim (default medium; --env
                      pointmaze-NAME says the same)
  --tasks LIST        comma-separated task ids (default 1,2,3,4,5)
  --episodes N        episodes per task (default 50)
  --max-steps N       step limit per episode (default 1000; cube-single 200, cube-double and
                      puzzles 500, the scene 750)
  --seed S            evaluation seed (default 0)
  --agent NAME        label written into the results (default "agent")
  --robot NAME        the robot interface spec the agent is served through, written into the
                      results as "robot" (demo.launch robot:=NAME; default: none)
  --observation-mode M  what the agent is served, state or pixels, written into the results
                      as "observation_mode" (demo.launch observation_mode:=pixels; default: none)
  --out FILE.json     results JSON (default: none)
  --plot FILE.png     trajectories drawn on the maze, 5 per task (default: none)
  --success-plot F    bar chart of success per task (PNG)
  --tasks-file YAML   custom tasks instead of the maze's five, e.g.
                        tasks:
                          - {id: 1, start: [0.0, 0.0], goal: [8.0, 0.0]}
                      (start/goal in metres; sent through reset + set_goal; msspr_make_tasks
                      draws random ones)
antmaze-medium, antmaze-large: the maze's 5 tasks with the ant (29-D goal states from the sim's
reset; success: the torso within 0.5 m of the goal); --maze and --tasks-file do not apply.
cube-single: the 5 tasks of OGBench's cube-single (success: the cube within 4 cm of the goal,
at the step that ends the episode); --maze, --plot and --tasks-file do not apply.
puzzle-3x3, puzzle-4x4, cube-double, scene: OGBench's 5 tasks of each (success: every
button's state as the goal's; both cubes within 4 cm of their own goals; the scene's cube,
drawer and window within 4 cm of theirs and both buttons as the goal's); --maze, --plot and
--tasks-file do not apply.
  --step-timeout S    seconds without a new observation before an episode counts as stalled (default 10)
  --sims N            drive N sim + agent pairs at once, in namespaces PREFIX0..PREFIX{N-1}, one
                      thread each, the episodes shared out; the results equal the serial run's
                      (default 1: the sim in msspr_eval's own namespace, as `reset` and `observation`)
  --sim-ns PREFIX     namespace prefix of the sims (default msspr_: relative, so /msspr_0, /msspr_1,
                      ... when msspr_eval runs in /); given with --sims 1, the one sim is PREFIX0
  --wait S            seconds to wait for each sim's reset service, observation topic and agent (default 60)
)";

struct EpisodeResult {
  bool success = false, stalled = false;
  int steps = 0;
  std::vector<Eigen::Vector2d> path;
  Eigen::Vector2d start, goal;
  std::optional<msspr::sim::CubeOutcome> cube = std::nullopt;  // cube-single: how the cube ended
};

// One sim + agent pair: the reset service and observation topic in namespace `ns`
// ("" is msspr_eval's own), with a callback queue of its own so that a worker
// thread can follow its episodes while other threads follow other sims.
class SimClient {
 public:
  SimClient(const std::string& ns, bool name_in_messages)
      : nh_(ns), label_(name_in_messages ? " on " + nh_.getNamespace() : "") {
    nh_.setCallbackQueue(&queue_);
    sub_ = nh_.subscribe<msspr::Observation>(
        "observation", 1000, [this](const msspr::Observation::ConstPtr& o) { inbox_.push_back(o); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    reset_ = nh_.serviceClient<msspr::Reset>("reset");
  }

  const std::string& Namespace() const { return nh_.getNamespace(); }
  std::string ResetService() { return reset_.getService(); }
  std::string ObservationTopic() const { return sub_.getTopic(); }
  bool HasReset() { return reset_.exists(); }
  bool HasObservations() const { return sub_.getNumPublishers() > 0; }
  std::string ActionTopic() const { return nh_.resolveName("action"); }
  // Whether anything (the agent under test) publishes the sim's action topic.
  bool HasAgent() const {
    ros::master::V_TopicInfo topics;
    if (!ros::master::getTopics(topics)) return false;
    // msspr/Action on action, or a robot's command served through a robot spec:
    // cmd_vel (pointmaze_base) or ee_twist (ur5e_cube).
    const std::string action = ActionTopic(), cmd_vel = nh_.resolveName("cmd_vel"),
                      ee_twist = nh_.resolveName("ee_twist");
    return std::any_of(topics.begin(), topics.end(), [&](const ros::master::TopicInfo& t) {
      return t.name == action || t.name == cmd_vel || t.name == ee_twist;
    });
  }
  int episodes_run() const { return episodes_run_; }

  // Runs one episode: reset with `req`, then follows the observations until success,
  // the last step, max_steps or step_timeout s without progress (stalled). With
  // `cube`, follows the cube too (r->cube). False with *error when the reset
  // fails; stops early (true) when `stop` is set.
  bool RunEpisode(const msspr::Reset::Request& req, int episode, int max_steps, double step_timeout,
                  bool cube, const std::atomic<bool>& stop, EpisodeResult* r, std::string* error) {
    msspr::Reset srv;
    srv.request = req;
    const bool answered = reset_.call(srv);
    if (!answered || !srv.response.ok) {
      *error = "reset of task " + std::to_string(req.task_id) + " (episode " +
               std::to_string(episode) + ") through " + reset_.getService() + " failed: " +
               (answered ? srv.response.message : "no answer (is the sim still running?)");
      return false;
    }
    ++episodes_run_;
    const auto& first = srv.response.observation;
    r->start = {first.state[0], first.state[1]};
    r->goal = {srv.response.goal[0], srv.response.goal[1]};
    r->path.push_back(r->start);
    constexpr size_t kCubeObs = msspr::sim::CubeEnv::kObservationSize;
    msspr::sim::CubeEpisodeTracker tracker;
    cube = cube && first.state.size() == kCubeObs && srv.response.goal.size() == kCubeObs;
    if (cube) tracker.Start(first.state.data(), srv.response.goal.data());
    const uint32_t id = first.episode_id;
    uint32_t last_step = 0;
    auto last_progress = ros::WallTime::now();
    bool finished = false;
    while (ros::ok() && !stop && !finished) {
      queue_.callAvailable(ros::WallDuration(0.01));
      if (inbox_.empty()) {
        if ((ros::WallTime::now() - last_progress).toSec() > step_timeout) {
          r->stalled = true;
          ROS_WARN(
              "msspr_eval: task %d episode %d stalled at step %u (no observation for %.0f s)%s",
              req.task_id, episode, last_step, step_timeout, label_.c_str());
          break;
        }
        continue;
      }
      while (!inbox_.empty() && !finished) {
        const auto o = inbox_.front();
        inbox_.pop_front();
        if (o->episode_id != id || o->step <= last_step) continue;  // older episode or re-send
        last_step = o->step;
        r->path.emplace_back(o->state[0], o->state[1]);
        if (cube && o->state.size() == kCubeObs) tracker.Observe(o->state.data());
        last_progress = ros::WallTime::now();
        if (o->success) {
          r->success = true;
          finished = true;
        } else if (static_cast<int>(o->step) >= max_steps || o->last) {
          finished = true;
        }
      }
    }
    r->steps = static_cast<int>(last_step);
    if (cube) r->cube = tracker.Finish(r->success);
    return true;
  }

 private:
  ros::CallbackQueue queue_;  // declared before the handle and subscriber that use it
  ros::NodeHandle nh_;
  std::string label_;
  ros::Subscriber sub_;
  ros::ServiceClient reset_;
  std::deque<msspr::Observation::ConstPtr>
      inbox_;  // every observation, in order (this sim's thread only)
  int episodes_run_ = 0;
};

// Polls until ready(client) holds for every client or `timeout_s` pass; returns the
// clients for which it does not (empty: all ready).
template <typename Pred>
std::vector<SimClient*> WaitForAll(std::vector<std::unique_ptr<SimClient>>& clients,
                                   double timeout_s, Pred ready) {
  const auto deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  std::vector<SimClient*> missing;
  for (;;) {
    missing.clear();
    for (auto& c : clients)
      if (!ready(*c)) missing.push_back(c.get());
    if (missing.empty() || !ros::ok() || ros::WallTime::now() > deadline) return missing;
    ros::WallDuration(0.05).sleep();
  }
}

// What the command line asks for. Every flag is checked before anything else runs.
struct EvalRequest {
  msspr::sim::EnvId env = msspr::sim::EnvId::kPointMaze;
  std::string maze;
  std::unique_ptr<msspr::sim::MazeMap> map;
  std::vector<int> tasks;
  std::map<int, std::pair<std::vector<float>, std::vector<float>>> custom;  // id -> start, goal
  int episodes = 0, max_steps = 0;
  uint64_t seed = 0;
  double step_timeout = 0, wait_s = 0;
  std::vector<std::string> namespaces;  // one per sim; {""}: msspr_eval's own namespace
  // Whether the tasks are the maze's (the point maze's and the ant's: their cells go into the
  // table and the JSON).
  bool maze_tasks() const {
    return env == msspr::sim::EnvId::kPointMaze || msspr::sim::IsAntMaze(env);
  }
};

// Throws std::invalid_argument (and CliArgs' errors) for a bad flag.
EvalRequest ParseRequest(const msspr::ros_bridge::CliArgs& args) {
  using msspr::sim::EnvId;
  EvalRequest q;
  if (!args.positional().empty())
    throw std::invalid_argument("unexpected argument '" + args.positional()[0] + "'");
  if (const std::string m = args.Get("observation-mode", "");
      !m.empty() && m != "state" && m != "pixels")
    throw std::invalid_argument("--observation-mode must be state or pixels, got '" + m + "'");
  std::string maze_arg;  // --env pointmaze-NAME or --maze NAME
  q.env = msspr::sim::ParseEnvFlag(args.Get("env", msspr::sim::EnvIdName(q.env)),
                                   args.Get("maze", ""), msspr::sim::AllEnvIds(), &maze_arg);
  const bool ant = msspr::sim::IsAntMaze(q.env);
  for (const char* f : {"maze", "plot", "tasks-file"})
    if ((q.env == EnvId::kCubeSingle || q.env == EnvId::kCubeDouble || q.env == EnvId::kScene ||
         msspr::sim::IsPuzzle(q.env) || (ant && std::string(f) != "plot")) &&
        args.Has(f))
      throw std::invalid_argument(std::string("--") + f + " does not apply to --env " +
                                  msspr::sim::EnvIdName(q.env));
  q.maze = ant ? msspr::sim::AntMazeName(q.env) : msspr::sim::PointMazeOrDefault(maze_arg);
  q.map = std::make_unique<msspr::sim::MazeMap>(msspr::sim::MazeMap::FromName(q.maze));
  const msspr::sim::EpisodeFlags f = msspr::sim::ReadEpisodeFlags(
      args, msspr::sim::EvalEpisodeCap(q.env), static_cast<long>(q.map->Tasks().size()),
      !args.Has("tasks-file"));
  q.tasks = f.tasks;
  if (args.Has("tasks-file")) {
    for (const auto& t : msspr::sim::LoadCustomTasks(args.Get("tasks-file", ""), q.map.get())) {
      q.custom[t.id] = {{static_cast<float>(t.start.x()), static_cast<float>(t.start.y())},
                        {static_cast<float>(t.goal.x()), static_cast<float>(t.goal.y())}};
      q.tasks.push_back(t.id);
    }
  }
  q.episodes = f.episodes;
  q.max_steps = f.max_steps;
  q.seed = f.seed;
  q.step_timeout = args.GetDouble("step-timeout", 10.0, 1e-3, 1e6);
  q.wait_s = args.GetDouble("wait", 60.0, 0.0, 1e6);
  const int sims = static_cast<int>(args.GetInt("sims", 1, 1, 256));
  if (sims == 1 && !args.Has("sim-ns")) {
    q.namespaces.push_back("");
  } else {
    const std::string prefix = args.Get("sim-ns", "msspr_");
    for (int i = 0; i < sims; ++i) {
      const std::string ns = prefix + std::to_string(i);
      std::string why;
      if (!ros::names::validate(ns, why))
        throw std::invalid_argument("--sim-ns '" + prefix + "' gives the namespace '" + ns +
                                    "', not a valid ROS name: " + why);
      q.namespaces.push_back(ns);
    }
  }
  return q;
}

// Waits for every sim's reset service and observations (fatal when missing) and
// for its agent (a warning). False when the evaluation cannot start.
bool ConnectSims(std::vector<std::unique_ptr<SimClient>>& clients, double wait_s) {
  for (auto& c : clients)
    ROS_INFO("msspr_eval: waiting for the sim's reset service %s", c->ResetService().c_str());
  const auto no_reset = WaitForAll(clients, wait_s, [](SimClient& c) { return c.HasReset(); });
  for (SimClient* c : no_reset)
    ROS_FATAL("msspr_eval: no reset service %s after %.0f s (is msspr_sim_node running in %s?)",
              c->ResetService().c_str(), wait_s, c->Namespace().c_str());
  if (!no_reset.empty() || !ros::ok()) return false;
  const auto silent = WaitForAll(clients, wait_s, [](SimClient& c) { return c.HasObservations(); });
  for (SimClient* c : silent)
    ROS_FATAL("msspr_eval: nothing publishes %s after %.0f s", c->ObservationTopic().c_str(),
              wait_s);
  if (!silent.empty() || !ros::ok()) return false;
  // An agent still loading (a policy checkpoint) would leave the first episode unanswered.
  for (SimClient* c : WaitForAll(clients, wait_s, [](SimClient& c) { return c.HasAgent(); }))
    ROS_WARN(
        "msspr_eval: nothing publishes %s after %.0f s (is the agent under test running there?); "
        "going on",
        c->ActionTopic().c_str(), wait_s);
  if (!ros::ok()) return false;
  ros::WallDuration(0.5).sleep();  // let the agents connect too
  return true;
}

// Runs every (task, episode) pair, in the serial order, each sim's thread taking the
// next one: results[task][episode]. False (and *error) when an episode could not run.
bool RunAllEpisodes(const EvalRequest& q, std::vector<std::unique_ptr<SimClient>>& clients,
                    std::vector<std::vector<EpisodeResult>>* results, std::string* error) {
  std::vector<std::pair<size_t, int>> work;
  for (size_t ti = 0; ti < q.tasks.size(); ++ti)
    for (int e = 0; e < q.episodes; ++e) work.emplace_back(ti, e);
  results->assign(q.tasks.size(), std::vector<EpisodeResult>(q.episodes));
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex mu;  // guards error and done
  std::vector<int> done(q.tasks.size(), 0);
  auto serve = [&](SimClient* client) {
    for (;;) {
      if (failed || !ros::ok()) return;
      const size_t k = next++;
      if (k >= work.size()) return;
      const auto [ti, e] = work[k];
      msspr::Reset::Request req;
      req.task_id = q.tasks[ti];
      req.seed = msspr::sim::EvalEpisodeSeed(q.seed, q.tasks[ti], e);
      if (auto it = q.custom.find(q.tasks[ti]); it != q.custom.end()) {
        req.start = it->second.first;
        req.goal = it->second.second;
      }
      EpisodeResult r;
      std::string why;
      const bool cube = q.env == msspr::sim::EnvId::kCubeSingle;
      if (!client->RunEpisode(req, e, q.max_steps, q.step_timeout, cube, failed, &r, &why)) {
        std::lock_guard<std::mutex> lock(mu);
        if (!failed.exchange(true)) *error = why;
        return;
      }
      (*results)[ti][static_cast<size_t>(e)] = std::move(r);
      std::lock_guard<std::mutex> lock(mu);
      if (++done[ti] == q.episodes) {  // the task's last episode, whichever sim ran it
        int ok = 0;
        for (auto& x : (*results)[ti]) ok += x.success;
        ROS_INFO("msspr_eval: task %d done: %d/%zu", q.tasks[ti], ok, (*results)[ti].size());
      }
    }
  };
  if (clients.size() > 1) {
    std::vector<std::thread> threads;
    for (auto& c : clients) threads.emplace_back(serve, c.get());
    for (auto& t : threads) t.join();
  } else {
    serve(clients[0].get());
  }
  return !failed;
}

// The results in the report format shared with the in-process evaluators.
msspr::sim::EvalReport MakeReport(const EvalRequest& q, const msspr::ros_bridge::CliArgs& args,
                                  const std::vector<std::vector<EpisodeResult>>& results,
                                  double wall) {
  msspr::sim::EvalReport report;
  report.env = msspr::sim::EnvLabel(q.env, q.maze);
  report.agent = args.Get("agent", "agent");
  report.robot = args.Get("robot", "");
  report.observation_mode = args.Get("observation-mode", "");
  report.episodes_per_task = q.episodes;
  report.max_steps = q.max_steps;
  report.seed = q.seed;
  report.wall_time_s = wall;
  for (size_t ti = 0; ti < q.tasks.size(); ++ti) {
    msspr::sim::TaskResult t;
    t.task_id = q.tasks[ti];
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
    if (auto it = q.custom.find(t.task_id); it != q.custom.end()) {
      t.start.assign(it->second.first.begin(), it->second.first.end());
      t.goal.assign(it->second.second.begin(), it->second.second.end());
    } else if (q.env == msspr::sim::EnvId::kCubeSingle) {  // the cube's start and goal xy (m)
      const auto& ct = msspr::sim::CubeSingleTasks()[static_cast<size_t>(t.task_id - 1)];
      t.start = {ct.start.x(), ct.start.y()};
      t.goal = {ct.goal.x(), ct.goal.y()};
    } else if (msspr::sim::IsPuzzle(q.env)) {  // the boards, row by row
      const auto& pt = msspr::sim::PuzzleTasks(
          msspr::sim::PuzzleSide(q.env))[static_cast<size_t>(t.task_id - 1)];
      t.start.assign(pt.start.begin(), pt.start.end());
      t.goal.assign(pt.goal.begin(), pt.goal.end());
    }
    report.tasks.push_back(t);
  }
  msspr::sim::FinalizeReport(&report);
  return report;
}

// --out, --success-plot and --plot. Throws std::runtime_error naming a path.
void WriteOutputs(const EvalRequest& q, const msspr::ros_bridge::CliArgs& args,
                  const msspr::sim::EvalReport& report,
                  const std::vector<std::vector<EpisodeResult>>& results) {
  if (args.Has("out")) {
    msspr::sim::WriteTextFile(args.Get("out", ""), q.maze_tasks()
                                                       ? msspr::sim::EvalReportJson(*q.map, report)
                                                       : msspr::sim::EvalReportJson(report));
    std::cout << "  results: " << args.Get("out", "") << "\n";
  }
  if (args.Has("success-plot")) {
    msspr::sim::SaveSuccessPlot(report, args.Get("success-plot", ""));
    std::cout << "  success per task: " << args.Get("success-plot", "") << "\n";
  }
  if (args.Has("plot")) {
    std::vector<std::vector<Eigen::Vector2d>> paths;
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> sg;
    std::vector<bool> ok;
    for (auto& task_results : results)
      for (size_t k = 0; k < task_results.size() && k < 5; ++k) {  // 5 per task keeps it readable
        paths.push_back(task_results[k].path);
        sg.emplace_back(task_results[k].start, task_results[k].goal);
        ok.push_back(task_results[k].success);
      }
    const std::string png = args.Get("plot", "");
    msspr::sim::SaveTrajectoryPlot(*q.map, paths, sg, ok, png);
    std::cout << "  picture: " << png << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_eval", ros::init_options::AnonymousName);
  std::unique_ptr<msspr::ros_bridge::CliArgs> args;
  EvalRequest q;
  try {
    args = std::make_unique<msspr::ros_bridge::CliArgs>(
        argc, argv, std::set<std::string>{"help"},
        std::set<std::string>{"env", "maze", "tasks", "episodes", "max-steps", "seed", "agent",
                              "out", "plot", "success-plot", "step-timeout", "tasks-file", "sims",
                              "sim-ns", "wait", "robot", "observation-mode"});
    if (args->Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    q = ParseRequest(*args);
  } catch (const std::exception& e) {
    std::cerr << "msspr_eval: " << e.what() << "\n" << kUsage;
    return 2;
  }
  const bool parallel = q.namespaces.size() > 1;
  std::vector<std::unique_ptr<SimClient>> clients;
  for (const auto& ns : q.namespaces) clients.push_back(std::make_unique<SimClient>(ns, parallel));
  if (!ConnectSims(clients, q.wait_s)) return 1;
  const auto wall0 = std::chrono::steady_clock::now();
  std::vector<std::vector<EpisodeResult>> results;
  std::string error;
  if (!RunAllEpisodes(q, clients, &results, &error)) {
    ROS_FATAL("msspr_eval: %s", error.c_str());
    return 1;
  }
  if (!ros::ok()) return 1;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const msspr::sim::EvalReport report = MakeReport(q, *args, results, wall);
  std::cout << (q.maze_tasks() ? msspr::sim::EvalReportTable(*q.map, report)
                               : msspr::sim::EvalReportTable(report));
  if (q.env == msspr::sim::EnvId::kCubeSingle) {  // how the failed episodes failed
    std::vector<msspr::sim::CubeOutcome> cubes;
    for (const auto& task_results : results)
      for (const auto& r : task_results)
        if (r.cube) cubes.push_back(*r.cube);
    std::cout << "  " << msspr::sim::DescribeCubeFailures(msspr::sim::CountCubeFailures(cubes))
              << "\n";
  }
  if (parallel) {
    std::cout << "  episodes per sim:";
    for (auto& c : clients) std::cout << " " << c->Namespace() << " " << c->episodes_run();
    std::cout << "\n";
  }
  std::cout << std::flush;
  try {
    WriteOutputs(q, *args, report, results);
  } catch (const std::exception& e) {
    std::cout << std::flush;
    ROS_FATAL("msspr_eval: %s", e.what());
    return 1;
  }
  std::cout << std::flush;
  return 0;
}
