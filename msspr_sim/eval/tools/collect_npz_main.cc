// msspr_collect_npz: point-maze datasets without ROS, straight to the core's
// .npz format (as OGBench's NAME.npz and NAME-val.npz). The episodes are those
// of msspr_collect (sim::CollectEpisode, episode k of seed S; k < --episodes
// is "train", the rest "val"), rendered on T threads, one rendering PointMaze
// each: float `observations` (states), `images` [N, 64, 64, 3] uint8,
// `actions`, `terminals`. For machines with MuJoCo but no ROS (e.g. a GPU
// machine training from pixels):
//
//   msspr_collect_npz --maze medium --episodes 1000 --val-episodes 100 --seed 7
//                     --threads 16 --out /data/pix.npz      # + /data/pix-val.npz
//
// --env antmaze-medium | antmaze-large: OGBench's antmaze datasets with the
// waypoint expert (ant_dataset.h, the episodes of msspr_collect --env
// antmaze-*): observations [N, 29], actions [N, 8], terminals, qpos [N, 15],
// qvel [N, 14].
#include <torch/torch.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "msspr_core/cli_args.h"
#include "msspr_core/dataset.h"
#include "msspr_core/npz.h"
#include "msspr_core/sac.h"
#include "msspr_eval/ant_dataset.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/point_maze.h"

namespace {

constexpr const char* kUsage = R"(usage: msspr_collect_npz --out FILE.npz [options]
Collects point-maze or ant-maze episodes (those of msspr_collect) into .npz datasets,
without ROS.
  --out FILE.npz      training split (required); the validation split goes to FILE-val.npz
  --env ENV           pointmaze | antmaze-medium | antmaze-large (default pointmaze)
  --maze NAME         arena, medium, large or giant (default medium; pointmaze; --env
                      pointmaze-NAME says the same)
  --kind KIND         navigate | stitch (default navigate)
  --episodes N        training episodes (default 1000)
  --val-episodes N    validation episodes (default episodes / 10)
  --length N          steps per episode (default 1001)
  --seed S            dataset seed (default 0)
  --threads N         collection threads (default: the machine's cores)
  --no-images         states only (default: 64x64 camera images too; pointmaze)
antmaze-*: the waypoint expert's datasets, states with qpos and qvel (no images);
stitch defaults to 5000 + 500 episodes of 201 steps.
  --expert FILE       the locomotion expert, sac_policy.pt of msspr_train_expert
                      (default: the shipped msspr_sim/experts/ant_xy_expert.pt)
  --noise STD         the expert's action noise std (default 0.2)
)";

// Collects episodes 0 .. total - 1 on `threads` threads. Each thread builds its
// own collector, collect(k) filling episode k, with make_collector(), one thread
// at a time (MuJoCo's XML compiler, the GL context and its function loader are
// not thread-safe); the episodes then run in parallel, each thread taking the
// next index. A progress line every `every` episodes and at the end. Returns the
// error of a thread that failed (the others stop), "" when all went well.
std::string CollectOnThreads(long total, long threads, int episode_length, long every,
                             std::chrono::steady_clock::time_point t0,
                             const std::function<std::function<void(long)>()>& make_collector) {
  std::atomic<long> next_k{0}, done{0};
  std::mutex err_mu, init_mu;
  std::string error;
  auto worker = [&]() {
    try {
      std::function<void(long)> collect;
      {
        std::lock_guard<std::mutex> lock(init_mu);
        collect = make_collector();
      }
      for (long k = next_k++; k < total; k = next_k++) {
        collect(k);
        const long d = ++done;
        if (d % every == 0 || d == total) {
          const double s =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          std::fprintf(stderr, "[msspr_collect_npz] %ld/%ld episodes, %.0f s, %.0f steps/s\n", d,
                       total, s, d * double(episode_length) / s);
        }
      }
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(err_mu);
      error = e.what();
      next_k = total;
    }
  };
  std::vector<std::thread> pool;
  for (long t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  return error;
}

// --env antmaze-*: CollectAntEpisode on T threads, one AntMaze and expert each.
int CollectAntNpz(msspr::sim::EnvId env_id, const std::string& expert,
                  const msspr::agent::AntCollectOptions& opt, long episodes, long val, long threads,
                  const std::string& out) {
  namespace sim = msspr::sim;
  const long total = episodes + val;
  std::vector<msspr::agent::AntEpisode> eps(static_cast<size_t>(total));
  const auto t0 = std::chrono::steady_clock::now();
  torch::set_num_threads(1);
  sim::AntMazeOptions eo;
  eo.maze = sim::AntMazeName(env_id);
  eo.max_episode_steps = opt.episode_length;
  const std::string error = CollectOnThreads(
      total, threads, opt.episode_length, 10, t0, [&]() -> std::function<void(long)> {
        auto policy = std::make_shared<msspr::core::SacPolicy>(expert);
        auto env = std::make_shared<sim::AntMaze>(eo);
        return [policy, env, &eps, &opt](long k) {
          eps[static_cast<size_t>(k)] =
              msspr::agent::CollectAntEpisode(*env, *policy, opt, static_cast<uint64_t>(k));
        };
      });
  if (!error.empty()) {
    std::fprintf(stderr, "msspr_collect_npz: %s\n", error.c_str());
    return 1;
  }
  auto write = [&](long from, long to, const std::string& path) {
    if (to <= from) return;
    std::vector<const msspr::agent::AntEpisode*> part;
    for (long k = from; k < to; ++k) part.push_back(&eps[static_cast<size_t>(k)]);
    msspr::agent::SaveAntNpz(part, path);
    std::fprintf(stderr, "[msspr_collect_npz] wrote %s: %ld episodes, %lld steps\n", path.c_str(),
                 to - from, static_cast<long long>((to - from) * opt.episode_length));
  };
  try {
    write(0, episodes, out);
    write(episodes, total, out.substr(0, out.size() - 4) + "-val.npz");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_collect_npz: %s\n", e.what());
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "[msspr_collect_npz] %ld episodes in %.1f s on %ld threads (%.0f steps/s)\n",
               total, s, threads, total * double(opt.episode_length) / s);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  namespace core = msspr::core;
  sim::CollectOptions opt;
  long episodes = 1000, val = -1, threads = 1;
  sim::EnvId env_id = sim::EnvId::kPointMaze;
  std::string out, expert;
  msspr::agent::AntCollectOptions ant;
  try {
    msspr::cli::CliArgs args(argc, argv, {"help", "no-images"},
                             {"out", "env", "maze", "kind", "episodes", "val-episodes", "length",
                              "seed", "threads", "expert", "noise"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw msspr::cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    out = args.Get("out", "");
    if (out.size() < 5 || out.substr(out.size() - 4) != ".npz")
      throw msspr::cli::CliError("--out FILE.npz is required");
    std::string maze;  // --env pointmaze-NAME or --maze NAME
    env_id = sim::ParseEnvFlag(
        args.Get("env", sim::EnvIdName(env_id)), args.Get("maze", ""),
        {sim::EnvId::kPointMaze, sim::EnvId::kAntMazeMedium, sim::EnvId::kAntMazeLarge}, &maze);
    const bool is_ant = sim::IsAntMaze(env_id);
    for (const char* f : {"maze", "no-images"})
      if (is_ant && args.Has(f))
        throw msspr::cli::CliError(std::string("--") + f + " does not apply to --env " +
                                   sim::EnvIdName(env_id));
    for (const char* f : {"expert", "noise"})
      if (!is_ant && args.Has(f))
        throw msspr::cli::CliError(std::string("--") + f +
                                   " needs --env antmaze-medium or antmaze-large");
    expert = args.Get("expert", sim::DefaultAntExpert());
    opt.maze = sim::PointMazeOrDefault(maze);
    opt.kind = sim::ParseDatasetKind(args.GetChoice("kind", "navigate", {"navigate", "stitch"}));
    const bool ant_stitch = is_ant && opt.kind == sim::DatasetKind::kStitch;
    episodes = args.GetInt("episodes", ant_stitch ? 5000 : 1000, 0, 100000000);
    val = args.GetInt("val-episodes", episodes / 10, 0, 100000000);
    opt.episode_length =
        static_cast<int>(args.GetInt("length", ant_stitch ? 201 : 1001, 2, 100000000));
    opt.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    ant.kind = opt.kind;
    ant.episode_length = opt.episode_length;
    ant.seed = opt.seed;
    ant.noise_std = args.GetDouble("noise", 0.2, 0.0, 1e6);
    const long cores = static_cast<long>(std::thread::hardware_concurrency());
    threads = args.GetInt("threads", cores > 0 ? cores : 1, 1, 4096);
    opt.images = !args.Has("no-images");
    if (episodes + val < 1) throw msspr::cli::CliError("no episodes to collect");
  } catch (const std::exception& e) {
    std::cerr << "msspr_collect_npz: " << e.what() << "\n" << kUsage;
    return 2;
  }
  if (sim::IsAntMaze(env_id))
    return CollectAntNpz(env_id, expert, ant, episodes, val, threads, out);
  const long total = episodes + val;
  const int size = 64;

  std::vector<sim::Episode> eps(static_cast<size_t>(total));
  const auto t0 = std::chrono::steady_clock::now();
  sim::PointMazeOptions eo;
  eo.maze = opt.maze;
  eo.enable_rendering = opt.images;
  eo.image_size = size;
  const std::string error = CollectOnThreads(
      total, threads, opt.episode_length, 50, t0, [&]() -> std::function<void(long)> {
        auto env = std::make_shared<sim::PointMaze>(eo);
        return [env, &eps, &opt](long k) {
          eps[static_cast<size_t>(k)] = sim::CollectEpisode(*env, opt, static_cast<uint64_t>(k));
        };
      });
  if (!error.empty()) {
    std::fprintf(stderr, "msspr_collect_npz: %s\n", error.c_str());
    return 1;
  }

  const core::ImageShape shape = opt.images ? core::ImageShape{size, size, 3} : core::ImageShape{};
  auto write = [&](long from, long to, const std::string& path) {
    if (to <= from) return;
    core::DatasetBuilder b(sim::PointMaze::kObsDim, sim::PointMaze::kActionDim, shape);
    b.Reserve((to - from) * opt.episode_length);
    for (long k = from; k < to; ++k) {
      sim::Episode& ep = eps[static_cast<size_t>(k)];
      b.AddEpisode(ep.observations, ep.actions, ep.images);
      ep = sim::Episode();  // free as we go
    }
    const int64_t n = b.size();
    core::SaveNpzDataset(b.Build(), path);
    std::fprintf(stderr, "[msspr_collect_npz] wrote %s: %ld episodes, %lld steps\n", path.c_str(),
                 to - from, static_cast<long long>(n));
  };
  try {
    write(0, episodes, out);
    write(episodes, total, out.substr(0, out.size() - 4) + "-val.npz");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_collect_npz: %s\n", e.what());
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "[msspr_collect_npz] %ld episodes in %.1f s on %ld threads\n", total, s,
               threads);
  return 0;
}
