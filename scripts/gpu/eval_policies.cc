// OGBench's evaluation protocol on a GPU machine without ROS or OpenCV: the
// 5 tasks of a point maze, N episodes each (PointMaze::ResetToTask(task,
// EvalEpisodeSeed(seed, task, e)), success when within the goal radius, at
// most 1000 steps), for each policy file given, from states or camera images
// (frame_stack 1). The episodes of a task run side by side, one batched
// forward pass per control step; the tasks run on their own threads, each
// with its own renderer and its own copy of the policy. One JSON line per
// policy on stdout. Built by scripts/gpu/train_pixels.sh; the same seeds as
// msspr_eval_inprocess, which remains the reference (it also writes plots).
//
//   eval_policies [--episodes 50] [--seed 0] [--device cuda] [--maze medium] POLICY...
#include <torch/torch.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "msspr_core/policy.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/point_maze.h"

namespace {

namespace core = msspr::core;
namespace sim = msspr::sim;

struct Options {
  int episodes = 50;
  uint64_t seed = 0;
  std::string device = "cuda";
  std::string maze = "medium";
  int max_steps = 1000;
};

// Success rate of `task` over options.episodes episodes.
double RunTask(const std::string& path, int task, const Options& o) {
  core::Policy policy = core::Policy::Load(path, torch::Device(o.device));
  const bool pixels = policy.pixels();
  if (pixels && policy.options().network.frame_stack > 1)
    throw std::invalid_argument(path + ": frame_stack > 1 is not supported here");
  const int size = pixels ? policy.options().network.image_height : 64;
  std::unique_ptr<sim::PointMaze> renderer;
  if (pixels) {
    sim::PointMazeOptions ro;
    ro.maze = o.maze;
    ro.enable_rendering = true;
    ro.image_size = size;
    static std::mutex init_mu;  // GL context creation is not thread-safe
    std::lock_guard<std::mutex> lock(init_mu);
    renderer = std::make_unique<sim::PointMaze>(ro);
  }
  const int64_t n = o.episodes, frame = int64_t{size} * size * 3;
  std::vector<std::unique_ptr<sim::PointMaze>> envs;
  std::vector<char> done(n, 0), ok(n, 0);
  torch::Tensor goal = pixels ? torch::empty({n, size, size, 3}, torch::kUInt8) : torch::empty({n, 2});
  for (int64_t e = 0; e < n; ++e) {
    sim::PointMazeOptions eo;
    eo.maze = o.maze;
    eo.max_episode_steps = o.max_steps;
    envs.push_back(std::make_unique<sim::PointMaze>(eo));
    envs[e]->ResetToTask(task, sim::EvalEpisodeSeed(o.seed, task, static_cast<int>(e)));
    if (pixels) {
      const auto g = renderer->RenderAt(envs[e]->goal());
      std::memcpy(goal[e].data_ptr<uint8_t>(), g.data(), frame);
    } else {
      goal[e][0] = envs[e]->goal().x();
      goal[e][1] = envs[e]->goal().y();
    }
    ok[e] = done[e] = envs[e]->success();
  }
  torch::InferenceMode guard;
  for (int step = 0; step < o.max_steps; ++step) {
    std::vector<int64_t> active;
    for (int64_t e = 0; e < n; ++e)
      if (!done[e]) active.push_back(e);
    if (active.empty()) break;
    const int64_t B = static_cast<int64_t>(active.size());
    torch::Tensor obs = pixels ? torch::empty({B, size, size, 3}, torch::kUInt8) : torch::empty({B, 2});
    for (int64_t b = 0; b < B; ++b) {
      const auto s = envs[active[b]]->state();
      if (pixels) {
        const auto img = renderer->RenderAt(s);
        std::memcpy(obs[b].data_ptr<uint8_t>(), img.data(), frame);
      } else {
        obs[b][0] = s.x();
        obs[b][1] = s.y();
      }
    }
    const torch::Tensor idx = torch::tensor(active, torch::kInt64);
    const torch::Tensor act = policy.Act(obs, goal.index_select(0, idx)).to(torch::kCPU).contiguous();
    auto a = act.accessor<float, 2>();
    for (int64_t b = 0; b < B; ++b) {
      sim::PointMaze& env = *envs[active[b]];
      env.Step(Eigen::Vector2d(a[b][0], a[b][1]));
      if (env.success()) ok[active[b]] = done[active[b]] = 1;
      else if (step + 1 >= o.max_steps) done[active[b]] = 1;
    }
  }
  int wins = 0;
  for (char c : ok) wins += c;
  return double(wins) / n;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::vector<std::string> policies;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "eval_policies: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--episodes") o.episodes = std::atoi(next().c_str());
    else if (a == "--seed") o.seed = std::strtoull(next().c_str(), nullptr, 10);
    else if (a == "--device") o.device = next();
    else if (a == "--maze") o.maze = next();
    else policies.push_back(a);
  }
  if (policies.empty() || o.episodes < 1) {
    std::fprintf(stderr, "usage: eval_policies [--episodes 50] [--seed 0] [--device cuda] [--maze medium] POLICY...\n");
    return 2;
  }
  torch::manual_seed(0);
  for (const std::string& path : policies) {
    const auto t0 = std::chrono::steady_clock::now();
    double success[5] = {0, 0, 0, 0, 0};
    std::string error;
    std::mutex mu;
    std::vector<std::thread> threads;
    for (int task = 1; task <= 5; ++task) {
      threads.emplace_back([&, task] {
        try {
          success[task - 1] = RunTask(path, task, o);
        } catch (const std::exception& e) {
          std::lock_guard<std::mutex> lock(mu);
          error = e.what();
        }
      });
    }
    for (auto& t : threads) t.join();
    if (!error.empty()) {
      std::fprintf(stderr, "eval_policies: %s: %s\n", path.c_str(), error.c_str());
      return 1;
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("{\"policy\": \"%s\", \"episodes\": %d, \"seed\": %llu, \"tasks\": [%.3f, %.3f, %.3f, %.3f, %.3f], "
                "\"mean_success\": %.4f, \"wall_s\": %.1f}\n",
                path.c_str(), o.episodes, static_cast<unsigned long long>(o.seed), success[0], success[1],
                success[2], success[3], success[4],
                (success[0] + success[1] + success[2] + success[3] + success[4]) / 5, wall);
    std::fflush(stdout);
  }
  return 0;
}
