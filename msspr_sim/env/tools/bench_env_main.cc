// Benchmark of the point-maze environment: env steps/s (state only), rendered
// frames/s at 64x64, and in-memory collection transitions/s with and without
// images. Usage: msspr_bench_env [--out FILE.json] [--maze medium]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/point_maze.h"

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  std::string out, maze = "medium";
  try {
    const msspr::cli::CliArgs args(argc, argv, {"help"}, {"out", "maze"});
    if (args.Has("help") || !args.positional().empty())
      throw msspr::cli::CliError(
          args.Has("help") ? "" : "unexpected argument '" + args.positional()[0] + "'");
    out = args.Get("out", "");
    maze = args.GetChoice("maze", "medium", {"arena", "medium", "large", "giant"});
  } catch (const msspr::cli::CliError& e) {
    if (*e.what()) std::cerr << "msspr_bench_env: " << e.what() << "\n";
    std::cerr << "usage: msspr_bench_env [--out FILE.json] [--maze NAME]\n";
    return *e.what() ? 2 : 0;
  }
  try {
    // Env steps/s, state only, random-ish actions.
    sim::PointMazeOptions opt;
    opt.maze = maze;
    sim::PointMaze env(opt);
    env.ResetRandom(1);
    const int kSteps = 200000;
    double checksum = 0.0;
    auto t0 = Clock::now();
    for (int k = 0; k < kSteps; ++k) {
      const double a = (k * 0.6180339887) - static_cast<int>(k * 0.6180339887);
      checksum += env.Step({2 * a - 1, 1 - 2 * a * a}).x();
      if (k % 1000 == 999) env.ResetRandom(k);
    }
    const double steps_per_s = kSteps / Seconds(t0, Clock::now());

    // Rendered frames/s at 64x64.
    opt.enable_rendering = true;
    opt.image_size = 64;
    sim::PointMaze renv(opt);
    renv.ResetRandom(2);
    std::vector<uint8_t> rgb(64 * 64 * 3);
    renv.Render(rgb.data());  // warm-up
    const int kFrames = 3000;
    t0 = Clock::now();
    for (int k = 0; k < kFrames; ++k) {
      renv.Step({0.5, -0.3});
      renv.Render(rgb.data());
      checksum += rgb[k % rgb.size()];
    }
    const double frames_per_s = kFrames / Seconds(t0, Clock::now());

    // Collection transitions/s.
    sim::CollectOptions copt;
    copt.maze = maze;
    const int kEpisodes = 100;
    t0 = Clock::now();
    for (int k = 0; k < kEpisodes; ++k)
      checksum += sim::CollectEpisode(env, copt, k).observations[0];
    const double collect_per_s = kEpisodes * copt.episode_length / Seconds(t0, Clock::now());
    copt.images = true;
    const int kImageEpisodes = 3;
    t0 = Clock::now();
    for (int k = 0; k < kImageEpisodes; ++k) {
      checksum += sim::CollectEpisode(renv, copt, k).images[k];
    }
    const double collect_img_per_s =
        kImageEpisodes * copt.episode_length / Seconds(t0, Clock::now());

    char json[1024];
    std::snprintf(json, sizeof(json),
                  "{\n  \"maze\": \"%s\",\n  \"env_steps_per_s\": %.1f,\n"
                  "  \"render_64x64_frames_per_s\": %.1f,\n"
                  "  \"collect_transitions_per_s\": %.1f,\n"
                  "  \"collect_transitions_with_images_per_s\": %.1f,\n"
                  "  \"render_backend\": \"%s\",\n  \"checksum\": %.6g\n}\n",
                  maze.c_str(), steps_per_s, frames_per_s, collect_per_s, collect_img_per_s,
#ifdef MSSPR_RENDER_BACKEND_OSMESA
                  "OSMESA",
#else
                  "EGL",
#endif
                  checksum);
    std::cout << json;
    if (!out.empty()) sim::WriteTextFile(out, json);  // throws, naming the path
  } catch (const std::exception& e) {
    std::cerr << "msspr_bench_env: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
