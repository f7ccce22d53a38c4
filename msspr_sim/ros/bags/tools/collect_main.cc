// msspr_collect: writes an offline dataset of the scripted expert straight into
// a rosbag (no master needed), in the layout of dataset_bag.h.
#include <ros/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <set>

#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/cli_args.h"
#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/cube_double_oracle.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/point_maze.h"
#include "msspr_sim/puzzle_dataset.h"
#include "msspr_sim/scene_oracle.h"
#ifdef MSSPR_COLLECT_ANT
#include "msspr_core/sac.h"
#include "msspr_eval/ant_dataset.h"
#include "msspr_sim/ant_maze.h"
#endif

namespace {

constexpr char kUsage[] = R"(usage: msspr_collect --out FILE.bag [options]
Writes an expert dataset of an msspr point maze, OGBench's cube-single-play,
cube-double-play, scene-play, puzzle-3x3-play or puzzle-4x4-play dataset of the
URDF arm,
or an ant maze's dataset, into a rosbag (LZ4).
  --env ENV              pointmaze | cube-single | cube-double | scene |
                         puzzle-3x3 | puzzle-4x4 | antmaze-medium | antmaze-large
                                                               (default pointmaze)
  --maze NAME            arena | medium | large | giant        (default medium;
                         --env pointmaze-NAME says the same)
  --kind KIND            navigate | stitch                     (default navigate)
  --episodes N           training episodes (default: 1000 navigate, 5000 stitch)
  --val-episodes N       validation episodes, split "val"     (default 10% of N)
  --length L             steps per episode (default: 1001 navigate, 201 stitch;
                         2001 for giant navigate)
  --noise STD            expert action noise std              (default 0.5)
  --images               render 64x64 camera images for every episode
  --image-episodes N     render images for the first N training episodes only
  --seed S               base seed; episode k uses EpisodeSeed(S, k) (default 0)
  --no-compress          write an uncompressed bag
  --quiet                no progress output
cube-single, cube-double, scene, puzzle-3x3, puzzle-4x4 (--maze, --kind and
--noise do not apply): the play oracle (CubePlayOracle and CubeDoublePlayOracle:
pick and place; ScenePlayOracle: the cube, the buttons, the drawer and the
window; PuzzlePlayOracle: presses of random buttons) from collection resets,
1000 + 100 episodes of 1001 steps by default; --episodes, --val-episodes, --length, --images,
--image-episodes, --seed as above, and
  --urdf FILE            the arm's URDF (default: the package's msspr_sim/urdf/ur5e_2f85.urdf)
antmaze-medium, antmaze-large (--maze and images do not apply): OGBench's
antmaze datasets with the waypoint expert; --kind, --episodes, --val-episodes,
--length, --seed as above, and
  --expert FILE          the locomotion expert, sac_policy.pt of msspr_train_expert
                         (default: the shipped msspr_sim/experts/ant_xy_expert.pt)
  --noise STD            the expert's action noise std (default 0.2)
Example (the full pointmaze-medium-navigate dataset, states only):
  rosrun msspr msspr_collect --maze medium --kind navigate --out medium-navigate.bag
Example (the full cube-single-play dataset, states only):
  rosrun msspr msspr_collect --env cube-single --out cube-single-play.bag
Example (the full puzzle-3x3-play dataset):
  rosrun msspr msspr_collect --env puzzle-3x3 --out puzzle-3x3-play.bag
Example (the full antmaze-medium-navigate dataset):
  rosrun msspr msspr_collect --env antmaze-medium --out antmaze-medium-navigate.bag
)";

// Progress line on stderr: every 200 ms on a terminal, every 5 s otherwise, and at the end.
struct Progress {
  bool quiet, tty;
  long total;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now(), last = t0;
  void Update(long done, uint64_t transitions) {
    const auto now = std::chrono::steady_clock::now();
    if (quiet || !(now - last > std::chrono::milliseconds(tty ? 200 : 5000) || done == total))
      return;
    last = now;
    const double s = std::chrono::duration<double>(now - t0).count();
    const double rate = transitions / std::max(s, 1e-9);
    const double eta = (total - done) * (s / done);
    std::fprintf(
        stderr,
        "%s[msspr_collect] %ld/%ld episodes  %.0f transitions/s  %.0fs elapsed  ETA %.0fs%s",
        tty ? "\r" : "", done, total, rate, s, eta, tty ? "   " : "\n");
  }
  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
};

// Writes episodes 0 .. episodes + val - 1 into `writer` (the first `episodes`
// split "train", the rest "val"; images for the first image_episodes) with
// write_one(k, meta, images), which collects episode k, fills the rest of
// `meta` (episode id, env and split set), writes it and returns its length;
// then the progress line's end and a summary naming `what`.
template <typename WriteOne>
void WriteAllEpisodes(const msspr::ros_bridge::CliArgs& args,
                      msspr::ros_bridge::DatasetBagWriter& writer, long episodes, long val,
                      long image_episodes, int episode_length, const std::string& env,
                      const std::string& what, WriteOne write_one) {
  const long total = episodes + val;
  Progress progress{args.Has("quiet"), isatty(STDERR_FILENO) != 0, total};
  uint64_t transitions = 0;
  for (long k = 0; k < total; ++k) {
    msspr::ros_bridge::EpisodeMeta meta;
    meta.episode_id = static_cast<uint64_t>(k);
    meta.env = env;
    meta.split = k < episodes ? "train" : "val";
    transitions += static_cast<uint64_t>(write_one(k, meta, k < image_episodes));
    progress.Update(k + 1, transitions);
  }
  writer.Close();
  const double s = progress.Elapsed();
  if (progress.quiet) return;
  if (progress.tty) std::fprintf(stderr, "\n");
  std::fprintf(stderr,
               "[msspr_collect] wrote %s: %s, %ld train + %ld val episodes of %d steps "
               "(%lu transitions, %ld with images) in %.1f s (%.0f steps/s)\n",
               args.Get("out", "").c_str(), what.c_str(), episodes, val, episode_length,
               static_cast<unsigned long>(transitions), std::min(image_episodes, total), s,
               transitions / std::max(s, 1e-9));
}

// An episode collector of a play env (the env kept alive by it): `collect_episode(env, options,
// k)` with the options' length, seed and images set.
template <class Options, class Env, class CollectEpisode>
std::function<msspr::sim::PlayEpisode(long, bool)> Collector(std::shared_ptr<Env> env, int length,
                                                             uint64_t seed,
                                                             CollectEpisode collect_episode) {
  return [env, length, seed, collect_episode](long k, bool images) {
    Options o;
    o.episode_length = length;
    o.seed = seed;
    o.images = images;
    return collect_episode(*env, o, static_cast<uint64_t>(k));
  };
}

// cube-single-play, cube-double-play, puzzle-3x3-play, puzzle-4x4-play: the play oracle's
// episodes (CollectCubeEpisode, CollectCubeDoubleEpisode, CollectPuzzleEpisode), state-only
// or with images.
int CollectManipulation(const msspr::ros_bridge::CliArgs& args, msspr::sim::EnvId env_id) {
  using namespace msspr;
  const std::string env_name = sim::EnvLabel(env_id);
  const bool puzzle = sim::IsPuzzle(env_id);
  int episode_length = 1001;
  uint64_t seed = 0;
  std::string urdf;
  long episodes = 0, val = 0, image_episodes = 0;
  try {
    if (!args.positional().empty())
      throw cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    for (const char* f : {"maze", "kind", "noise"})
      if (args.Has(f))
        throw cli::CliError(std::string("--") + f + " does not apply to --env " + env_name);
    episodes = args.GetInt("episodes", 1000, 1, 100000000);
    val = args.GetInt("val-episodes", episodes / 10, 0, 100000000);
    episode_length = static_cast<int>(args.GetInt("length", 1001, 2, 1000000));
    seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    image_episodes =
        args.Has("images") ? episodes + val : args.GetInt("image-episodes", 0, 0, 100000000);
    urdf = args.Get("urdf", sim::DefaultArmUrdf());
  } catch (const std::exception& e) {
    std::cerr << "msspr_collect: " << e.what() << "\n" << kUsage;
    return 2;
  }
  ros::Time::init();
  sim::CubeEnvOptions cube_opt;
  sim::PuzzleEnvOptions puzzle_opt;
  sim::CubeDoubleEnvOptions double_opt;
  cube_opt.urdf_path = puzzle_opt.urdf_path = double_opt.urdf_path = urdf;
  cube_opt.enable_rendering = puzzle_opt.enable_rendering = double_opt.enable_rendering =
      image_episodes > 0;
  // OGBench's visual look for the cubes (the goal markers hidden)
  cube_opt.scene.pixel_style = double_opt.scene.pixel_style = image_episodes > 0;
  std::function<sim::PlayEpisode(long, bool)> collect;  // episode k, with images or not
  int obs_dim = sim::CubeEnv::kObservationSize;
  if (puzzle) {
    puzzle_opt.side = sim::PuzzleSide(env_id);
    auto env = std::make_shared<sim::PuzzleEnv>(puzzle_opt);
    obs_dim = env->observation_size();
    collect =
        Collector<sim::PuzzleCollectOptions>(env, episode_length, seed, sim::CollectPuzzleEpisode);
  } else if (env_id == sim::EnvId::kScene) {
    sim::SceneEnvOptions scene_opt;
    scene_opt.urdf_path = urdf;
    scene_opt.enable_rendering = image_episodes > 0;
    obs_dim = sim::SceneEnv::kObservationSize;
    collect = Collector<sim::SceneCollectOptions>(std::make_shared<sim::SceneEnv>(scene_opt),
                                                  episode_length, seed, sim::CollectSceneEpisode);
  } else if (env_id == sim::EnvId::kCubeDouble) {
    obs_dim = sim::CubeDoubleEnv::kObservationSize;
    collect = Collector<sim::CubeDoubleCollectOptions>(
        std::make_shared<sim::CubeDoubleEnv>(double_opt), episode_length, seed,
        sim::CollectCubeDoubleEpisode);
  } else {
    collect = Collector<sim::CubeCollectOptions>(std::make_shared<sim::CubeEnv>(cube_opt),
                                                 episode_length, seed, sim::CollectCubeEpisode);
  }
  const double control_dt = cube_opt.scene.timestep * cube_opt.substeps;
  ros_bridge::DatasetBagWriter writer(args.Get("out", ""), control_dt, !args.Has("no-compress"));
  long redrawn = 0;  // the scene's episodes drawn again by its health check
  WriteAllEpisodes(args, writer, episodes, val, image_episodes, episode_length, env_name,
                   env_name + "-play", [&](long k, ros_bridge::EpisodeMeta& meta, bool images) {
                     const sim::PlayEpisode ep = collect(k, images);
                     redrawn += ep.seed != sim::EpisodeSeed(seed, static_cast<uint64_t>(k));
                     meta.seed = ep.seed;
                     meta.start.assign(ep.observations.begin(), ep.observations.begin() + obs_dim);
                     // play data has no goal: meta.goal stays empty, so no step is marked success
                     writer.WriteEpisode(meta, ep.length, obs_dim, sim::CubeEnv::kActionSize,
                                         ep.observations.data(), ep.actions.data(),
                                         images ? ep.images.data() : nullptr, cube_opt.image_size,
                                         cube_opt.success_distance);
                     return ep.length;
                   });
  if (env_id == sim::EnvId::kScene && !args.Has("quiet"))
    std::fprintf(stderr,
                 "[msspr_collect] %ld of %ld episodes drawn again (the cube left the table's "
                 "sight; EpisodeInfo.seed is the seed used)\n",
                 redrawn, episodes + val);
  return 0;
}

// antmaze-medium / antmaze-large: agent::CollectAntEpisode per episode (states only).
int CollectAnt(const msspr::ros_bridge::CliArgs& args, msspr::sim::EnvId env_id) {
  using namespace msspr;
  const std::string env_name = sim::EnvIdName(env_id);
#ifndef MSSPR_COLLECT_ANT
  (void)args;
  std::cerr << "msspr_collect: --env " << env_name
            << " needs the waypoint expert (msspr_eval_core); this build has no msspr_core\n";
  return 2;
#else
  agent::AntCollectOptions opt;
  std::string expert_path;
  long episodes = 0, val = 0;
  try {
    if (!args.positional().empty())
      throw cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    for (const char* f : {"maze", "images", "image-episodes"})
      if (args.Has(f))
        throw cli::CliError(std::string("--") + f + " does not apply to --env " + env_name);
    expert_path = args.Get("expert", sim::DefaultAntExpert());
    opt.kind = sim::ParseDatasetKind(args.GetChoice("kind", "navigate", {"navigate", "stitch"}));
    const bool stitch = opt.kind == sim::DatasetKind::kStitch;
    episodes = args.GetInt("episodes", stitch ? 5000 : 1000, 1, 100000000);
    val = args.GetInt("val-episodes", episodes / 10, 0, 100000000);
    opt.episode_length = static_cast<int>(args.GetInt("length", stitch ? 201 : 1001, 2, 1000000));
    opt.noise_std = args.GetDouble("noise", 0.2, 0.0, 1e6);
    opt.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
  } catch (const std::exception& e) {
    std::cerr << "msspr_collect: " << e.what() << "\n" << kUsage;
    return 2;
  }
  ros::Time::init();
  core::SacPolicy policy(expert_path);
  sim::AntMazeOptions env_opt;
  env_opt.maze = sim::AntMazeName(env_id);
  env_opt.max_episode_steps = opt.episode_length;
  sim::AntMaze env(env_opt);
  const double control_dt = sim::kAntTimestep * sim::AntMaze::kFrameSkip;
  ros_bridge::DatasetBagWriter writer(args.Get("out", ""), control_dt, !args.Has("no-compress"));
  WriteAllEpisodes(args, writer, episodes, val, 0, opt.episode_length, sim::EnvLabel(env_id),
                   sim::EnvLabel(env_id) + "-" + sim::DatasetKindName(opt.kind),
                   [&](long k, ros_bridge::EpisodeMeta& meta, bool) {
                     const agent::AntEpisode ep =
                         agent::CollectAntEpisode(env, policy, opt, static_cast<uint64_t>(k));
                     meta.seed = ep.seed;
                     meta.start.assign(ep.observations.begin(),
                                       ep.observations.begin() + sim::AntMaze::kObsDim);
                     meta.goal.assign(ep.goal.data(), ep.goal.data() + ep.goal.size());
                     // success as the env counts it: the torso's xy within the radius
                     writer.WriteEpisode(meta, ep.length, sim::AntMaze::kObsDim,
                                         sim::AntMaze::kActionDim, ep.observations.data(),
                                         ep.actions.data(), nullptr, 0, env_opt.success_radius,
                                         /*success_dims=*/2);
                     return ep.length;
                   });
  return 0;
#endif
}

}  // namespace

int main(int argc, char** argv) {
  using namespace msspr;
  std::unique_ptr<ros_bridge::CliArgs> parsed;
  try {
    parsed = std::make_unique<ros_bridge::CliArgs>(
        argc, argv, std::set<std::string>{"images", "no-compress", "quiet", "help"},
        std::set<std::string>{"out", "env", "urdf", "maze", "kind", "episodes", "val-episodes",
                              "length", "noise", "image-episodes", "seed", "expert"});
  } catch (const std::exception& e) {
    std::cerr << "msspr_collect: " << e.what() << "\n" << kUsage;
    return 2;
  }
  const ros_bridge::CliArgs& args = *parsed;
  try {
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.Has("out")) {
      std::cerr << "msspr_collect: --out FILE.bag is required\n" << kUsage;
      return 2;
    }
    sim::EnvId env_id = sim::EnvId::kPointMaze;
    std::string maze;  // --env pointmaze-NAME or --maze NAME
    try {
      env_id = sim::ParseEnvFlag(args.Get("env", "pointmaze"), args.Get("maze", ""),
                                 sim::AllEnvIds(), &maze);
      if (env_id != sim::EnvId::kCubeSingle && env_id != sim::EnvId::kCubeDouble &&
          !sim::IsPuzzle(env_id) && args.Has("urdf"))
        throw cli::CliError(
            "--urdf needs an arm env: cube-single, cube-double, puzzle-3x3 or "
            "puzzle-4x4");
      if (!sim::IsAntMaze(env_id) && args.Has("expert"))
        throw cli::CliError("--expert needs --env antmaze-medium or antmaze-large");
    } catch (const std::exception& e) {
      std::cerr << "msspr_collect: " << e.what() << "\n" << kUsage;
      return 2;
    }
    switch (env_id) {
      case sim::EnvId::kCubeSingle:
      case sim::EnvId::kPuzzle3x3:
      case sim::EnvId::kPuzzle4x4:
      case sim::EnvId::kCubeDouble:
      case sim::EnvId::kScene:
        return CollectManipulation(args, env_id);
      case sim::EnvId::kAntMazeMedium:
      case sim::EnvId::kAntMazeLarge:
        return CollectAnt(args, env_id);
      case sim::EnvId::kPointMaze:
        break;
    }
    sim::CollectOptions opt;
    long episodes = 0, val = 0, image_episodes = 0;
    try {  // every flag is checked first: a bad one is a usage error (exit 2)
      if (!args.positional().empty())
        throw cli::CliError("unexpected argument '" + args.positional()[0] + "'");
      opt.maze = sim::PointMazeOrDefault(maze);
      opt.kind = sim::ParseDatasetKind(args.GetChoice("kind", "navigate", {"navigate", "stitch"}));
      const bool stitch = opt.kind == sim::DatasetKind::kStitch;
      episodes =
          args.GetInt("episodes", stitch ? 5000 : (opt.maze == "giant" ? 500 : 1000), 1, 100000000);
      val = args.GetInt("val-episodes", episodes / 10, 0, 100000000);
      opt.episode_length = static_cast<int>(
          args.GetInt("length", stitch ? 201 : (opt.maze == "giant" ? 2001 : 1001), 2, 1000000));
      opt.noise_std = args.GetDouble("noise", 0.5, 0.0, 1e6);
      opt.seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
      image_episodes =
          args.Has("images") ? episodes + val : args.GetInt("image-episodes", 0, 0, 100000000);
    } catch (const std::exception& e) {
      std::cerr << "msspr_collect: " << e.what() << "\n" << kUsage;
      return 2;
    }
    ros::Time::init();
    sim::PointMazeOptions env_opt;
    env_opt.maze = opt.maze;
    env_opt.enable_rendering = image_episodes > 0;
    sim::PointMaze env(env_opt);
    const std::string env_name = sim::EnvLabel(sim::EnvId::kPointMaze, opt.maze);
    const double control_dt = 0.02 * sim::PointMaze::kFrameSkip;
    ros_bridge::DatasetBagWriter writer(args.Get("out", ""), control_dt, !args.Has("no-compress"));
    WriteAllEpisodes(
        args, writer, episodes, val, image_episodes, opt.episode_length, env_name, env_name,
        [&](long k, ros_bridge::EpisodeMeta& meta, bool images) {
          sim::CollectOptions o = opt;
          o.images = images;
          const sim::Episode ep = sim::CollectEpisode(env, o, static_cast<uint64_t>(k));
          meta.seed = ep.seed;
          meta.start = {static_cast<float>(ep.start.x()), static_cast<float>(ep.start.y())};
          meta.goal = {static_cast<float>(ep.goal.x()), static_cast<float>(ep.goal.y())};
          writer.WriteEpisode(meta, ep.length, sim::PointMaze::kObsDim, sim::PointMaze::kActionDim,
                              ep.observations.data(), ep.actions.data(),
                              images ? ep.images.data() : nullptr, env_opt.image_size,
                              env_opt.success_radius);
          return ep.length;
        });
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "msspr_collect: error: " << e.what() << "\n";
    return 1;
  }
}
