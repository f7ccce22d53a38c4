#include "msspr_sim/env_id.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {
namespace {

constexpr const char* kPointMazePrefix = "pointmaze-";

std::string JoinNames(const std::vector<EnvId>& ids) {
  std::string s;
  for (EnvId id : ids) s += (s.empty() ? "" : " ") + EnvIdName(id);
  return s;
}

}  // namespace

const std::vector<EnvId>& AllEnvIds() {
  static const std::vector<EnvId> ids = {
      EnvId::kPointMaze, EnvId::kCubeSingle, EnvId::kAntMazeMedium, EnvId::kAntMazeLarge,
      EnvId::kPuzzle3x3, EnvId::kPuzzle4x4,  EnvId::kCubeDouble,    EnvId::kScene};
  return ids;
}

std::string EnvIdName(EnvId id) {
  switch (id) {
    case EnvId::kPointMaze:
      return "pointmaze";
    case EnvId::kCubeSingle:
      return "cube-single";
    case EnvId::kAntMazeMedium:
      return "antmaze-medium";
    case EnvId::kAntMazeLarge:
      return "antmaze-large";
    case EnvId::kPuzzle3x3:
      return "puzzle-3x3";
    case EnvId::kPuzzle4x4:
      return "puzzle-4x4";
    case EnvId::kCubeDouble:
      return "cube-double";
    case EnvId::kScene:
      return "scene";
  }
  throw std::invalid_argument("EnvIdName: not an EnvId (" + std::to_string(static_cast<int>(id)) +
                              ")");
}

std::optional<EnvId> TryParseEnvId(const std::string& name) {
  for (EnvId id : AllEnvIds()) {
    if (EnvIdName(id) == name) return id;
  }
  return std::nullopt;
}

EnvId ParseEnvId(const std::string& name) {
  if (const auto id = TryParseEnvId(name)) return *id;
  throw std::invalid_argument("unknown env id '" + name +
                              "'; valid ids: " + JoinNames(AllEnvIds()));
}

std::set<std::string> EnvIdNames(const std::vector<EnvId>& ids) {
  std::set<std::string> names;
  for (EnvId id : ids) names.insert(EnvIdName(id));
  return names;
}

const std::vector<EnvId>& AntMazeEnvIds() {
  static const std::vector<EnvId> ids = {EnvId::kAntMazeMedium, EnvId::kAntMazeLarge};
  return ids;
}

bool IsAntMaze(EnvId id) { return id == EnvId::kAntMazeMedium || id == EnvId::kAntMazeLarge; }

std::string AntMazeName(EnvId id) {
  switch (id) {
    case EnvId::kAntMazeMedium:
      return "medium";
    case EnvId::kAntMazeLarge:
      return "large";
    case EnvId::kPointMaze:
    case EnvId::kCubeSingle:
    case EnvId::kPuzzle3x3:
    case EnvId::kPuzzle4x4:
    case EnvId::kCubeDouble:
    case EnvId::kScene:
      break;
  }
  throw std::invalid_argument("'" + EnvIdName(id) +
                              "' is no ant maze; ant mazes: " + JoinNames(AntMazeEnvIds()));
}

int EvalEpisodeCap(EnvId id) {
  switch (id) {
    case EnvId::kCubeSingle:
      return 200;
    case EnvId::kPuzzle3x3:
    case EnvId::kPuzzle4x4:
    case EnvId::kCubeDouble:
      return 500;
    case EnvId::kScene:
      return 750;
    case EnvId::kPointMaze:
    case EnvId::kAntMazeMedium:
    case EnvId::kAntMazeLarge:
      break;
  }
  return 1000;
}

EnvId AntMazeEnvId(const std::string& maze) {
  for (EnvId id : AntMazeEnvIds()) {
    if (AntMazeName(id) == maze) return id;
  }
  std::ostringstream msg;
  msg << "no ant maze '" << maze << "'; ant mazes:";
  for (EnvId id : AntMazeEnvIds()) msg << ' ' << AntMazeName(id);
  throw std::invalid_argument(msg.str());
}

bool IsPuzzle(EnvId id) { return id == EnvId::kPuzzle3x3 || id == EnvId::kPuzzle4x4; }

int PuzzleSide(EnvId id) {
  if (id == EnvId::kPuzzle3x3) return 3;
  if (id == EnvId::kPuzzle4x4) return 4;
  throw std::invalid_argument("'" + EnvIdName(id) +
                              "' is no puzzle; puzzles: puzzle-3x3 puzzle-4x4");
}

std::string EnvLabel(EnvId id, const std::string& maze) {
  if (id != EnvId::kPointMaze) return EnvIdName(id);
  if (maze.empty()) throw std::invalid_argument("EnvLabel: the point maze's label needs a maze");
  return kPointMazePrefix + maze;
}

std::optional<EnvLabelParts> ParseEnvLabel(const std::string& label) {
  const std::string prefix = kPointMazePrefix;
  if (label.size() > prefix.size() && label.compare(0, prefix.size(), prefix) == 0)
    return EnvLabelParts{EnvId::kPointMaze, label.substr(prefix.size())};
  const auto id = TryParseEnvId(label);
  if (!id || *id == EnvId::kPointMaze) return std::nullopt;
  return EnvLabelParts{*id, ""};
}

EnvId ParseEnvFlag(const std::string& env, const std::string& maze_flag,
                   const std::vector<EnvId>& allowed, std::string* maze) {
  const std::vector<std::string> mazes = MazeMap::Names();
  const bool point_allowed =
      std::find(allowed.begin(), allowed.end(), EnvId::kPointMaze) != allowed.end();
  std::string name = env, from_env;
  const std::string prefix = EnvIdName(EnvId::kPointMaze) + "-";
  if (point_allowed && env.rfind(prefix, 0) == 0 &&
      std::find(mazes.begin(), mazes.end(), env.substr(prefix.size())) != mazes.end()) {
    name = EnvIdName(EnvId::kPointMaze);
    from_env = env.substr(prefix.size());
  }
  const std::optional<EnvId> id = TryParseEnvId(name);
  if (!id || std::find(allowed.begin(), allowed.end(), *id) == allowed.end()) {
    std::string list;
    for (EnvId a : allowed) {
      list += (list.empty() ? "" : ", ") + EnvIdName(a);
      if (a == EnvId::kPointMaze)
        for (const auto& m : mazes) list += ", " + prefix + m;
    }
    throw std::invalid_argument("--env '" + env + "' is not one of: " + list);
  }
  if (!from_env.empty() && !maze_flag.empty() && maze_flag != from_env)
    throw std::invalid_argument("--env " + env + " and --maze " + maze_flag +
                                " name two mazes: give one");
  *maze = from_env.empty() ? maze_flag : from_env;
  return *id;
}

std::string PointMazeOrDefault(const std::string& maze) {
  const std::string m = maze.empty() ? "medium" : maze;
  const std::vector<std::string> names = MazeMap::Names();
  if (std::find(names.begin(), names.end(), m) != names.end()) return m;
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());
  std::string list;
  for (const auto& n : sorted) list += (list.empty() ? "" : ", ") + n;
  throw std::invalid_argument("--maze '" + m + "' is not one of: " + list);
}

}  // namespace msspr::sim
