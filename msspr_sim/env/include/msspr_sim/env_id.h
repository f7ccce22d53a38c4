// The environments msspr simulates, named in one place: the ids that --env
// and ~env take ("pointmaze", "cube-single", "antmaze-medium",
// "antmaze-large") and the env labels that datasets and evaluation reports
// carry ("pointmaze-medium", "cube-single", "antmaze-large"). Tools and nodes
// parse a name once, where it comes in (a flag, a parameter, a bag), and
// switch on the enum from then on.
#ifndef MSSPR_SIM_ENV_ID_H_
#define MSSPR_SIM_ENV_ID_H_

#include <optional>
#include <set>
#include <string>
#include <vector>

namespace msspr::sim {

enum class EnvId {
  kPointMaze,
  kCubeSingle,
  kAntMazeMedium,
  kAntMazeLarge,
  kPuzzle3x3,
  kPuzzle4x4,
  kCubeDouble,
  kScene
};

// Every id, in the order above.
const std::vector<EnvId>& AllEnvIds();

// "pointmaze", "cube-single", "antmaze-medium", "antmaze-large", "puzzle-3x3", "puzzle-4x4",
// "cube-double", "scene".
std::string EnvIdName(EnvId id);
// The inverse of EnvIdName; nullopt for any other name.
std::optional<EnvId> TryParseEnvId(const std::string& name);
// The inverse of EnvIdName; throws std::invalid_argument naming `name` and
// listing the valid ids.
EnvId ParseEnvId(const std::string& name);
// The names of `ids`, as a set (the choices of cli::CliArgs::GetChoice).
std::set<std::string> EnvIdNames(const std::vector<EnvId>& ids = AllEnvIds());

// A tool's --env and --maze as one idea: --env pointmaze-NAME is --env pointmaze --maze NAME
// (the names msspr_train --eval-env and the bags' EpisodeInfo.env use). `maze_flag` is --maze
// ("" when not given). Returns the env among `allowed` and sets *maze to the point maze's map
// (from --env or --maze; "" when neither names one). Throws std::invalid_argument naming the
// value and every accepted name, or when --env and --maze name two mazes.
EnvId ParseEnvFlag(const std::string& env, const std::string& maze_flag,
                   const std::vector<EnvId>& allowed, std::string* maze);

// The point maze's map of a tool: `maze` (from ParseEnvFlag), "medium" when empty. Throws
// std::invalid_argument "--maze 'X' is not one of: arena, giant, ..." for another name.
std::string PointMazeOrDefault(const std::string& maze);

// The ant mazes: antmaze-medium, antmaze-large.
const std::vector<EnvId>& AntMazeEnvIds();
bool IsAntMaze(EnvId id);
// antmaze-large -> "large" (a MazeMap name, for AntMazeOptions::maze); throws
// std::invalid_argument for an id that is no ant maze.
std::string AntMazeName(EnvId id);
// "large" -> antmaze-large; throws std::invalid_argument naming `maze` and
// listing the ant mazes.
EnvId AntMazeEnvId(const std::string& maze);

// OGBench's step limit of an evaluation episode of `id`: 1000 (the mazes), 200 (cube-single),
// 500 (cube-double, the puzzles), 750 (the scene); each env's own max_episode_steps default.
int EvalEpisodeCap(EnvId id);

// The puzzles: puzzle-3x3 and puzzle-4x4.
bool IsPuzzle(EnvId id);
// puzzle-3x3 -> 3, puzzle-4x4 -> 4; throws std::invalid_argument for another id.
int PuzzleSide(EnvId id);

// The env label of a dataset or an evaluation report: "pointmaze-<maze>"
// (maze: a MazeMap name), "cube-single", or the ant maze's id (`maze` is
// ignored but for the point maze). Throws std::invalid_argument for the point
// maze without a maze.
std::string EnvLabel(EnvId id, const std::string& maze = "");
// An env label read back: the env and, for the point maze, the maze name
// (unchecked; "" for the others).
struct EnvLabelParts {
  EnvId id;
  std::string maze;
};
// nullopt for a label of no msspr env (e.g. a robot's own bags, or "").
std::optional<EnvLabelParts> ParseEnvLabel(const std::string& label);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_ENV_ID_H_
