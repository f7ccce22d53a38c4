// ROS-free dataset collection for a GPU machine: the same episodes as
// `msspr_collect` (msspr::sim::CollectEpisode, episode k of seed S), rendered
// on T threads (one rendering PointMaze each), written as the core's .npz
// dataset (float `observations` = states, `images` [N, 64, 64, 3] uint8,
// `actions`, `terminals`). Train and validation splits go to two files, as
// OGBench's NAME.npz and NAME-val.npz. Built by scripts/gpu/train_pixels.sh
// against msspr_env's sources and msspr_core's npz writer:
//
//   collect_npz --maze medium --episodes 1000 --val-episodes 100 --seed 7 \
//       --threads 16 --out /data/pix.npz          # + /data/pix-val.npz
//
// Episode k < episodes is "train", the rest "val", as in msspr_collect.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "msspr_core/dataset.h"
#include "msspr_core/npz.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/point_maze.h"

namespace {

const char kUsage[] =
    "usage: collect_npz --out FILE.npz [--maze medium] [--kind navigate|stitch]\n"
    "                   [--episodes 1000] [--val-episodes 100] [--length 1001] [--seed 0]\n"
    "                   [--threads N] [--no-images]\n";

[[noreturn]] void Usage(const std::string& why) {
  std::fprintf(stderr, "collect_npz: %s\n%s", why.c_str(), kUsage);
  std::exit(2);
}

long ToLong(const std::string& flag, const char* v) {
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (end == v || *end != '\0' || x < 0) Usage(flag + " needs a non-negative integer, got '" + v + "'");
  return x;
}

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  namespace core = msspr::core;
  sim::CollectOptions opt;
  opt.images = true;
  long episodes = 1000, val = -1, threads = std::thread::hardware_concurrency();
  std::string out;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) Usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--out") out = next();
    else if (a == "--maze") opt.maze = next();
    else if (a == "--kind") opt.kind = sim::ParseDatasetKind(next());
    else if (a == "--episodes") episodes = ToLong(a, next());
    else if (a == "--val-episodes") val = ToLong(a, next());
    else if (a == "--length") opt.episode_length = static_cast<int>(ToLong(a, next()));
    else if (a == "--seed") opt.seed = static_cast<uint64_t>(ToLong(a, next()));
    else if (a == "--threads") threads = ToLong(a, next());
    else if (a == "--no-images") opt.images = false;
    else Usage("unknown argument '" + a + "'");
  }
  if (out.size() < 5 || out.substr(out.size() - 4) != ".npz") Usage("--out FILE.npz is required");
  if (val < 0) val = episodes / 10;
  if (threads < 1) threads = 1;
  const long total = episodes + val;
  const int size = 64;

  std::vector<sim::Episode> eps(static_cast<size_t>(total));
  std::atomic<long> next_k{0}, done{0};
  std::mutex err_mu, init_mu;
  std::string error;
  const auto t0 = std::chrono::steady_clock::now();
  auto worker = [&]() {
    try {
      sim::PointMazeOptions eo;
      eo.maze = opt.maze;
      eo.enable_rendering = opt.images;
      eo.image_size = size;
      // Construction (MuJoCo's XML compiler, the GL context and its function
      // loader) is not thread-safe: one at a time; episodes then run in parallel.
      std::unique_ptr<sim::PointMaze> env_ptr;
      {
        std::lock_guard<std::mutex> lock(init_mu);
        env_ptr = std::make_unique<sim::PointMaze>(eo);
      }
      sim::PointMaze& env = *env_ptr;
      for (long k = next_k++; k < total; k = next_k++) {
        eps[static_cast<size_t>(k)] = sim::CollectEpisode(env, opt, static_cast<uint64_t>(k));
        const long d = ++done;
        if (d % 50 == 0 || d == total) {
          const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          std::fprintf(stderr, "[collect_npz] %ld/%ld episodes, %.0f s, %.0f steps/s\n", d, total, s,
                       d * double(opt.episode_length) / s);
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
  if (!error.empty()) {
    std::fprintf(stderr, "collect_npz: %s\n", error.c_str());
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
    std::fprintf(stderr, "[collect_npz] wrote %s: %ld episodes, %lld steps\n", path.c_str(), to - from,
                 static_cast<long long>(n));
  };
  try {
    write(0, episodes, out);
    write(episodes, total, out.substr(0, out.size() - 4) + "-val.npz");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "collect_npz: %s\n", e.what());
    return 1;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "[collect_npz] %ld episodes in %.1f s on %ld threads\n", total, s, threads);
  return 0;
}
