// Benchmark of the cube-single environment: collection rows/s with the play
// oracle (state only and with 64x64 images), and the implied time for the
// 1000 + 100 episode cube-single-play dataset on one core.
// Usage: msspr_bench_cube --urdf FILE [--out FILE.json] [--episodes N]
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/eval_protocol.h"

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  std::string out, urdf;
  int episodes = 3;
  try {
    const msspr::cli::CliArgs args(argc, argv, {"help"}, {"out", "urdf", "episodes"});
    if (args.Has("help") || !args.positional().empty())
      throw msspr::cli::CliError(
          args.Has("help") ? "" : "unexpected argument '" + args.positional()[0] + "'");
    out = args.Get("out", "");
    urdf = args.Get("urdf", "");
    if (urdf.empty()) throw msspr::cli::CliError("--urdf is required");
    episodes = static_cast<int>(args.GetInt("episodes", 3, 1, 1100));
  } catch (const msspr::cli::CliError& e) {
    if (*e.what()) std::cerr << "msspr_bench_cube: " << e.what() << "\n";
    std::cerr << "usage: msspr_bench_cube --urdf FILE [--out FILE.json] [--episodes N]\n";
    return *e.what() ? 2 : 0;
  }
  try {
    sim::CubeEnvOptions eo;
    eo.urdf_path = urdf;
    sim::CubeEnv env(eo);
    sim::CubeCollectOptions co;
    double checksum = 0;
    auto t0 = Clock::now();
    for (int k = 0; k < episodes; ++k)
      checksum += sim::CollectCubeEpisode(env, co, k).observations.back();
    const double rows_per_s = episodes * co.episode_length / Seconds(t0, Clock::now());

    eo.enable_rendering = true;
    eo.scene.pixel_style = true;
    sim::CubeEnv renv(eo);
    co.images = true;
    t0 = Clock::now();
    checksum += sim::CollectCubeEpisode(renv, co, 0).images.back();
    const double image_rows_per_s = co.episode_length / Seconds(t0, Clock::now());

    const double dataset_rows = 1100.0 * co.episode_length;
    char json[1024];
    std::snprintf(json, sizeof(json),
                  "{\n  \"env\": \"cube-single\",\n  \"collect_rows_per_s\": %.1f,\n"
                  "  \"collect_rows_with_images_per_s\": %.1f,\n"
                  "  \"dataset_1100_episodes_minutes\": %.1f,\n"
                  "  \"dataset_1100_episodes_with_images_minutes\": %.1f,\n"
                  "  \"checksum\": %.6g\n}\n",
                  rows_per_s, image_rows_per_s, dataset_rows / rows_per_s / 60,
                  dataset_rows / image_rows_per_s / 60, checksum);
    std::cout << json;
    if (!out.empty()) sim::WriteTextFile(out, json);  // throws, naming the path
  } catch (const std::exception& e) {
    std::cerr << "msspr_bench_cube: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
