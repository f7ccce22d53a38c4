#include "msspr_sim/env_id.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_sim/ant_maze.h"
#include "msspr_sim/cube_double_env.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/scene_env.h"

namespace msspr::sim {
namespace {

// The names are user-visible (--env, ~env, bag and report labels): spelled
// out here so that a change to env_id.cc fails.
TEST(EnvIdTest, EveryIdHasItsNameAndRoundTrips) {
  const std::vector<std::pair<EnvId, std::string>> expected = {
      {EnvId::kPointMaze, "pointmaze"},          {EnvId::kCubeSingle, "cube-single"},
      {EnvId::kAntMazeMedium, "antmaze-medium"}, {EnvId::kAntMazeLarge, "antmaze-large"},
      {EnvId::kPuzzle3x3, "puzzle-3x3"},         {EnvId::kPuzzle4x4, "puzzle-4x4"},
      {EnvId::kCubeDouble, "cube-double"},       {EnvId::kScene, "scene"}};
  ASSERT_EQ(AllEnvIds().size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    const auto& [id, name] = expected[i];
    EXPECT_EQ(AllEnvIds()[i], id) << name;
    EXPECT_EQ(EnvIdName(id), name);
    EXPECT_EQ(ParseEnvId(name), id) << name;
    EXPECT_EQ(TryParseEnvId(name), id) << name;
  }
  EXPECT_EQ(EnvIdNames(),
            (std::set<std::string>{"pointmaze", "cube-single", "antmaze-medium", "antmaze-large",
                                   "puzzle-3x3", "puzzle-4x4", "cube-double", "scene"}));
  EXPECT_EQ(EnvIdNames({EnvId::kPointMaze, EnvId::kCubeSingle}),
            (std::set<std::string>{"pointmaze", "cube-single"}));
}

TEST(EnvIdTest, AnUnknownIdIsRejectedByNameWithTheValidOnes) {
  for (const std::string bad : {"cube-triple", "pointmaze-medium", "PointMaze", "antmaze", ""}) {
    EXPECT_EQ(TryParseEnvId(bad), std::nullopt) << bad;
    try {
      ParseEnvId(bad);
      ADD_FAILURE() << "'" << bad << "' was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()),
                "unknown env id '" + bad +
                    "'; valid ids: pointmaze cube-single antmaze-medium antmaze-large "
                    "puzzle-3x3 puzzle-4x4 cube-double scene");
    }
  }
}

TEST(EnvIdTest, PuzzlesHaveTheirSides) {
  EXPECT_TRUE(IsPuzzle(EnvId::kPuzzle3x3));
  EXPECT_TRUE(IsPuzzle(EnvId::kPuzzle4x4));
  EXPECT_FALSE(IsPuzzle(EnvId::kCubeSingle));
  EXPECT_EQ(PuzzleSide(EnvId::kPuzzle3x3), 3);
  EXPECT_EQ(PuzzleSide(EnvId::kPuzzle4x4), 4);
  EXPECT_THROW(PuzzleSide(EnvId::kAntMazeLarge), std::invalid_argument);
  EXPECT_EQ(EnvLabel(EnvId::kPuzzle4x4), "puzzle-4x4");
  EXPECT_EQ(ParseEnvLabel("puzzle-3x3")->id, EnvId::kPuzzle3x3);
}

TEST(EnvIdTest, AntMazesMapToTheirMazes) {
  EXPECT_EQ(AntMazeEnvIds(), (std::vector<EnvId>{EnvId::kAntMazeMedium, EnvId::kAntMazeLarge}));
  for (EnvId id : AllEnvIds()) {
    const bool ant = id == EnvId::kAntMazeMedium || id == EnvId::kAntMazeLarge;
    EXPECT_EQ(IsAntMaze(id), ant) << EnvIdName(id);
    if (ant) {
      EXPECT_EQ(AntMazeEnvId(AntMazeName(id)), id);
      EXPECT_EQ("antmaze-" + AntMazeName(id), EnvIdName(id));
    } else {
      EXPECT_THROW(AntMazeName(id), std::invalid_argument) << EnvIdName(id);
    }
  }
  EXPECT_EQ(AntMazeName(EnvId::kAntMazeLarge), "large");
  try {
    AntMazeEnvId("giant");
    ADD_FAILURE() << "antmaze giant was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "no ant maze 'giant'; ant mazes: medium large");
  }
}

TEST(EnvIdTest, EnvLabelsRoundTrip) {
  EXPECT_EQ(EnvLabel(EnvId::kPointMaze, "medium"), "pointmaze-medium");
  EXPECT_EQ(EnvLabel(EnvId::kCubeSingle), "cube-single");
  EXPECT_EQ(EnvLabel(EnvId::kAntMazeLarge), "antmaze-large");
  EXPECT_EQ(EnvLabel(EnvId::kAntMazeLarge, "medium"), "antmaze-large");  // the maze is the id's
  EXPECT_THROW(EnvLabel(EnvId::kPointMaze), std::invalid_argument);
  for (EnvId id : AllEnvIds()) {
    const std::string maze = id == EnvId::kPointMaze ? "giant" : "";
    const auto parts = ParseEnvLabel(EnvLabel(id, maze));
    ASSERT_TRUE(parts.has_value()) << EnvIdName(id);
    EXPECT_EQ(parts->id, id);
    EXPECT_EQ(parts->maze, maze);
  }
  // Labels of no msspr env (e.g. a robot's own bags).
  for (const std::string other : {"", "pointmaze", "pointmaze-", "ur5e", "antmaze-giant"})
    EXPECT_EQ(ParseEnvLabel(other).has_value(), false) << other;
}

// The evaluation caps are OGBench's and each env's own default.
TEST(EnvIdTest, EvalEpisodeCapsAreOGBenchsAndTheEnvsDefaults) {
  EXPECT_EQ(EvalEpisodeCap(EnvId::kPointMaze), 1000);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kAntMazeMedium), 1000);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kAntMazeLarge), AntMazeOptions().max_episode_steps);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kCubeSingle), 200);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kCubeSingle), CubeEnvOptions().max_episode_steps);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kPuzzle3x3), 500);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kPuzzle4x4), PuzzleEnvOptions().max_episode_steps);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kCubeDouble), CubeDoubleEnvOptions().max_episode_steps);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kScene), 750);
  EXPECT_EQ(EvalEpisodeCap(EnvId::kScene), SceneEnvOptions().max_episode_steps);
}

}  // namespace
// --env pointmaze-NAME is --env pointmaze --maze NAME, in every tool that takes --env.
TEST(EnvIdTest, PointmazeNameIsTheMazeFlag) {
  std::string maze;
  EXPECT_EQ(ParseEnvFlag("pointmaze-large", "", AllEnvIds(), &maze), EnvId::kPointMaze);
  EXPECT_EQ(maze, "large");
  EXPECT_EQ(ParseEnvFlag("pointmaze", "giant", AllEnvIds(), &maze), EnvId::kPointMaze);
  EXPECT_EQ(maze, "giant");
  EXPECT_EQ(ParseEnvFlag("pointmaze", "", AllEnvIds(), &maze), EnvId::kPointMaze);
  EXPECT_EQ(maze, "");
  EXPECT_EQ(ParseEnvFlag("pointmaze-medium", "medium", AllEnvIds(), &maze), EnvId::kPointMaze);
  EXPECT_EQ(ParseEnvFlag("antmaze-medium", "", AllEnvIds(), &maze), EnvId::kAntMazeMedium);
  EXPECT_EQ(maze, "");
  try {
    ParseEnvFlag("pointmaze-medium", "large", AllEnvIds(), &maze);
    FAIL() << "two mazes accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("name two mazes"), std::string::npos) << e.what();
  }
  try {
    ParseEnvFlag("pointmaze-nowhere", "", AllEnvIds(), &maze);
    FAIL() << "an unknown maze accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pointmaze-medium"), std::string::npos) << e.what();
  }
  // An env the tool does not take is refused, named among the accepted ones.
  EXPECT_THROW(ParseEnvFlag("cube-single", "", {EnvId::kPointMaze}, &maze), std::invalid_argument);
}

}  // namespace msspr::sim
