#include "maze_evaluator.h"

#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>

#include <torch/torch.h>

#include "msspr_core/policy.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/point_maze.h"

namespace msspr::agent {

namespace {

// One running episode.
struct Slot {
  int task_index = 0, episode = 0;
  std::unique_ptr<sim::PointMaze> env;
  bool done = false, success = false;
  int steps = 0;
  std::vector<uint8_t> frames;  // [H, W, 3 * frame_stack], oldest first (pixels)
  std::vector<uint8_t> goal_frames;
  std::vector<Eigen::Vector2d> path;
};

}  // namespace

MazeEvalResult EvaluateOnMaze(core::Policy& policy, const MazeEvalOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const sim::MazeMap map = sim::MazeMap::FromName(options.maze);
  for (int t : options.tasks)
    if (t < 1 || t > static_cast<int>(map.Tasks().size()))
      throw std::invalid_argument("EvaluateOnMaze: task " + std::to_string(t) + " is not a task of " +
                                  options.maze);
  const bool pixels = policy.pixels();
  if (!pixels && policy.obs_dim() != sim::PointMaze::kObsDim)
    throw std::invalid_argument("EvaluateOnMaze: the policy expects " + std::to_string(policy.obs_dim()) +
                                "-dimensional observations, the point maze gives 2");
  if (policy.action_dim() != sim::PointMaze::kActionDim)
    throw std::invalid_argument("EvaluateOnMaze: the policy has " + std::to_string(policy.action_dim()) +
                                " action dimensions, the point maze takes 2");
  const auto& net = policy.options().network;
  const int stack = std::max(1, net.frame_stack);
  const int size = net.image_height;
  if (pixels && (net.image_width != size || net.image_channels != 3))
    throw std::invalid_argument("EvaluateOnMaze: pixels policies need square RGB images");

  std::unique_ptr<sim::PointMaze> renderer;
  if (pixels) {
    sim::PointMazeOptions ro;
    ro.maze = options.maze;
    ro.enable_rendering = true;
    ro.image_size = size;
    renderer = std::make_unique<sim::PointMaze>(ro);
  }
  const size_t frame_bytes = static_cast<size_t>(size) * size * 3;
  auto stack_image = [&](const std::vector<uint8_t>& img) {  // one frame repeated, HWC interleaved
    std::vector<uint8_t> out(frame_bytes * stack);
    const size_t px = static_cast<size_t>(size) * size;
    for (size_t p = 0; p < px; ++p)
      for (int k = 0; k < stack; ++k) std::memcpy(&out[(p * stack + k) * 3], &img[p * 3], 3);
    return out;
  };

  auto push_frame = [&](Slot& s, const Eigen::Vector2d& xy, bool fill) {
    const auto img = renderer->RenderAt(xy);
    if (fill) {
      s.frames = stack_image(img);
    } else {  // drop the oldest frame (channels are interleaved per pixel: HWC with C = 3 * stack)
      std::vector<uint8_t> next(s.frames.size());
      const size_t px = static_cast<size_t>(size) * size;
      for (size_t p = 0; p < px; ++p) {
        std::memcpy(&next[p * 3 * stack], &s.frames[p * 3 * stack + 3], 3 * (stack - 1));
        std::memcpy(&next[p * 3 * stack + 3 * (stack - 1)], &img[p * 3], 3);
      }
      s.frames.swap(next);
    }
  };
  sim::PointMazeOptions eo;
  eo.maze = options.maze;
  eo.max_episode_steps = options.max_steps;
  std::vector<Slot> slots;
  for (size_t ti = 0; ti < options.tasks.size(); ++ti)
    for (int e = 0; e < options.episodes; ++e) {
      Slot s;
      s.task_index = static_cast<int>(ti);
      s.episode = e;
      s.env = std::make_unique<sim::PointMaze>(eo);
      const auto start = s.env->ResetToTask(options.tasks[ti], sim::EvalEpisodeSeed(options.seed, options.tasks[ti], e));
      if (options.keep_paths) s.path.push_back(start);
      if (pixels) {
        push_frame(s, start, /*fill=*/true);
        s.goal_frames = stack_image(renderer->RenderAt(s.env->goal()));
      }
      s.success = s.env->success();
      s.done = s.success;
      slots.push_back(std::move(s));
    }

  torch::InferenceMode guard;
  for (int step = 0; step < options.max_steps; ++step) {
    std::vector<Slot*> active;
    for (auto& s : slots)
      if (!s.done) active.push_back(&s);
    if (active.empty()) break;
    const int64_t B = static_cast<int64_t>(active.size());
    torch::Tensor obs, goal;
    if (pixels) {
      obs = torch::empty({B, size, size, 3 * stack}, torch::kUInt8);
      goal = torch::empty({B, size, size, 3 * stack}, torch::kUInt8);
      for (int64_t b = 0; b < B; ++b) {
        std::memcpy(obs[b].data_ptr<uint8_t>(), active[b]->frames.data(), frame_bytes * stack);
        std::memcpy(goal[b].data_ptr<uint8_t>(), active[b]->goal_frames.data(), frame_bytes * stack);
      }
    } else {
      obs = torch::empty({B, 2}, torch::kFloat32);
      goal = torch::empty({B, 2}, torch::kFloat32);
      auto o = obs.accessor<float, 2>();
      auto g = goal.accessor<float, 2>();
      for (int64_t b = 0; b < B; ++b) {
        const auto s = active[b]->env->state(), gl = active[b]->env->goal();
        o[b][0] = static_cast<float>(s.x());
        o[b][1] = static_cast<float>(s.y());
        g[b][0] = static_cast<float>(gl.x());
        g[b][1] = static_cast<float>(gl.y());
      }
    }
    const torch::Tensor act = policy.Act(obs, goal).to(torch::kCPU).contiguous();
    auto a = act.accessor<float, 2>();
    for (int64_t b = 0; b < B; ++b) {
      Slot& s = *active[b];
      const auto next = s.env->Step(Eigen::Vector2d(a[b][0], a[b][1]));
      ++s.steps;
      if (options.keep_paths) s.path.push_back(next);
      if (s.env->success()) {
        s.success = true;
        s.done = true;
      } else if (s.steps >= options.max_steps) {
        s.done = true;
      } else if (pixels) {
        push_frame(s, next, /*fill=*/false);
      }
    }
  }

  MazeEvalResult r;
  r.tasks = options.tasks;
  const size_t nt = options.tasks.size();
  r.success.assign(nt, 0.0);
  r.mean_steps_success.assign(nt, 0.0);
  std::vector<int> ok(nt, 0);
  if (options.keep_paths) {
    r.paths.resize(nt);
    r.start_goal.resize(nt);
    r.episode_success.resize(nt);
  }
  for (auto& s : slots) {
    const size_t ti = static_cast<size_t>(s.task_index);
    if (s.success) {
      ++ok[ti];
      r.mean_steps_success[ti] += s.steps;
    }
    if (options.keep_paths) {
      r.start_goal[ti].emplace_back(s.path.front(), s.env->goal());
      r.paths[ti].push_back(std::move(s.path));
      r.episode_success[ti].push_back(s.success);
    }
  }
  for (size_t ti = 0; ti < nt; ++ti) {
    r.success[ti] = options.episodes ? double(ok[ti]) / options.episodes : 0.0;
    if (ok[ti]) r.mean_steps_success[ti] /= ok[ti];
    r.mean_success += r.success[ti] / nt;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

void WriteResultsJson(const MazeEvalResult& result, const MazeEvalOptions& options, const std::string& agent,
                      const std::string& path) {
  sim::EvalReport report;
  report.env = "pointmaze-" + options.maze;
  report.agent = agent;
  report.episodes_per_task = options.episodes;
  report.max_steps = options.max_steps;
  report.seed = options.seed;
  report.wall_time_s = result.seconds;
  for (size_t i = 0; i < result.tasks.size(); ++i) {
    sim::TaskResult t;
    t.task_id = result.tasks[i];
    t.success = result.success[i];
    t.episodes = options.episodes;
    t.mean_steps_successful = result.mean_steps_success[i];
    report.tasks.push_back(t);
  }
  sim::FinalizeReport(&report);
  sim::WriteTextFile(path, sim::EvalReportJson(sim::MazeMap::FromName(options.maze), report));
}

}  // namespace msspr::agent
