// msspr_make_tasks: N random custom evaluation tasks (start and goal in two free
// cells of a point maze), deterministic by seed, written as the YAML that
// msspr_eval --tasks-file and msspr_train --eval-tasks-file read. A policy that
// only learned OGBench's five tasks shows on these.
#include <iostream>
#include <set>
#include <string>

#include "msspr_core/cli_args.h"
#include "msspr_sim/custom_tasks.h"
#include "msspr_sim/eval_protocol.h"

namespace {

constexpr char kUsage[] = R"(usage: msspr_make_tasks [options]
Draws N random (start, goal) pairs of free cells of a point maze (cell centre + U[-noise, noise]
per axis) and writes them as a tasks file for msspr_eval --tasks-file / msspr_train --eval-tasks-file.
  --maze NAME        arena, medium, large or giant (default medium)
  --n N              number of tasks (default 10)
  --seed S           seed (default 0); the same seed gives the same tasks
  --min-cells K      at least K moves (4-connected) between start and goal cells (default 2)
  --noise M          metres of uniform noise per axis around the cell centres (default 1.0)
  --out FILE.yaml    output file (default: standard output)
)";

}  // namespace

int main(int argc, char** argv) {
  namespace sim = msspr::sim;
  std::string maze, out;
  int n = 10, min_cells = 2;
  uint64_t seed = 0;
  double noise = 1.0;
  try {
    const msspr::cli::CliArgs args(argc, argv, {"help"},
                                   {"maze", "n", "seed", "min-cells", "noise", "out"});
    if (args.Has("help") || !args.positional().empty())
      throw msspr::cli::CliError(
          args.Has("help") ? "" : "unexpected argument '" + args.positional()[0] + "'");
    const auto names = sim::MazeMap::Names();
    maze = args.GetChoice("maze", "medium", std::set<std::string>(names.begin(), names.end()));
    n = static_cast<int>(args.GetInt("n", 10, 1, 100000));
    seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    min_cells = static_cast<int>(args.GetInt("min-cells", 2, 1, 10000));
    noise = args.GetDouble("noise", 1.0, 0.0, sim::kCellSize / 2 - sim::kAgentRadius);
    out = args.Get("out", "");
  } catch (const msspr::cli::CliError& e) {
    if (*e.what()) std::cerr << "msspr_make_tasks: " << e.what() << "\n";
    std::cerr << kUsage;
    return *e.what() ? 2 : 0;
  }
  try {
    const auto map = sim::MazeMap::FromName(maze);
    const auto tasks = sim::RandomCustomTasks(map, n, seed, min_cells, noise);
    const std::string yaml =
        sim::CustomTasksYaml(map, tasks,
                             "msspr_make_tasks --maze " + maze + " --n " + std::to_string(n) +
                                 " --seed " + std::to_string(seed) + " --min-cells " +
                                 std::to_string(min_cells) + " --noise " + std::to_string(noise));
    if (out.empty()) {
      std::cout << yaml;
    } else {
      sim::WriteTextFile(out, yaml);
      std::cerr << "msspr_make_tasks: " << tasks.size() << " tasks on maze " << maze << " -> "
                << out << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "msspr_make_tasks: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
