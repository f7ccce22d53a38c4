#include "msspr_sim/custom_tasks.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>

#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_plot.h"

namespace msspr::sim {
namespace {

std::string TmpFile(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = std::filesystem::path(MSSPR_TEST_TMPDIR) / "custom_tasks";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << text;
  return path;
}

// What a loader error says, or "" when it loads.
std::string LoadError(const std::string& text, const MazeMap* map) {
  const std::string path = TmpFile("bad.yaml", text);
  try {
    LoadCustomTasks(path, map);
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << "the error names the file: " << what;
    return what;
  }
  return "";
}

TEST(CustomTasksTest, RandomTasksAreDeterministicFreeAndFarEnoughApart) {
  const MazeMap map = MazeMap::FromName("medium");
  const auto a = RandomCustomTasks(map, 50, 3, /*min_cells=*/4);
  const auto b = RandomCustomTasks(map, 50, 3, 4);
  const auto c = RandomCustomTasks(map, 50, 4, 4);
  ASSERT_EQ(a.size(), 50u);
  bool differ = false;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].id, static_cast<int>(k) + 1);
    EXPECT_EQ(a[k].start, b[k].start);
    EXPECT_EQ(a[k].goal, b[k].goal);
    differ = differ || a[k].start != c[k].start;
    const Cell s = map.XYToCell(a[k].start), g = map.XYToCell(a[k].goal);
    EXPECT_FALSE(map.IsWall(s));
    EXPECT_FALSE(map.IsWall(g));
    EXPECT_GE(map.BfsDistance(s, g), 4);
    // Within the noise of the cell centre, and a sphere's radius off the walls.
    EXPECT_LE((a[k].start - map.CellCenter(s)).cwiseAbs().maxCoeff(), 1.0 + 1e-9);
    EXPECT_LE((a[k].goal - map.CellCenter(g)).cwiseAbs().maxCoeff(), 1.0 + 1e-9);
  }
  EXPECT_TRUE(differ) << "another seed, other tasks";
  EXPECT_THROW(RandomCustomTasks(map, 5, 0, 1000), std::invalid_argument);
  EXPECT_THROW(RandomCustomTasks(map, 0, 0), std::invalid_argument);
}

TEST(CustomTasksTest, YamlRoundTripsExactly) {
  const MazeMap map = MazeMap::FromName("large");
  const auto tasks = RandomCustomTasks(map, 20, 11, 2, 0.8);
  const std::string path =
      TmpFile("round_trip.yaml", CustomTasksYaml(map, tasks, "made by a test\nsecond line"));
  const auto back = LoadCustomTasks(path, &map);
  ASSERT_EQ(back.size(), tasks.size());
  for (size_t k = 0; k < tasks.size(); ++k) {
    EXPECT_EQ(back[k].id, tasks[k].id);
    EXPECT_EQ(back[k].start, tasks[k].start);  // millimetres both ways
    EXPECT_EQ(back[k].goal, tasks[k].goal);
  }
  // The shipped example file loads.
  const MazeMap medium = MazeMap::FromName("medium");
  EXPECT_EQ(LoadCustomTasks(std::string(MSSPR_SOURCE_DIR) + "/config/eval_tasks_medium_easy.yaml",
                            &medium)
                .size(),
            3u);
}

TEST(CustomTasksTest, BadFilesSayWhatIsWrong) {
  const MazeMap map = MazeMap::FromName("medium");
  EXPECT_NE(LoadError("tasks: []\n", &map).find("non-empty list 'tasks'"), std::string::npos);
  EXPECT_NE(LoadError("tasks:\n  - {id: 1, start: [0, 0], goal: [4, 0], speed: 2}\n", &map)
                .find("unknown key 'speed'"),
            std::string::npos);
  EXPECT_NE(LoadError("tasks:\n  - {id: 1, start: [0, 0], goal: [4, 0]}\n  - {id: 1, start: [0, "
                      "0], goal: [4, 0]}\n",
                      &map)
                .find("appears twice"),
            std::string::npos);
  EXPECT_NE(LoadError("tasks:\n  - {id: 2, start: [0, 0, 1], goal: [4, 0]}\n", &map)
                .find("task 2: start"),
            std::string::npos);
  EXPECT_NE(LoadError("tasks:\n  - {id: 3, start: [0, 0], goal: [-4, 0]}\n", &map)
                .find("task 3: goal (-4.000, 0.000) is inside a wall"),
            std::string::npos);
  EXPECT_NE(LoadError("maze: giant\ntasks:\n  - {id: 1, start: [0, 0], goal: [4, 0]}\n", &map)
                .find("'giant', not 'medium'"),
            std::string::npos);
  EXPECT_NE(LoadError("tasks: [\n", &map), "");
  // Without a map, walls and the maze name are not checked.
  EXPECT_EQ(LoadError("maze: giant\ntasks:\n  - {id: 3, start: [0, 0], goal: [-4, 0]}\n", nullptr),
            "");
  EXPECT_THROW(LoadCustomTasks("/nonexistent/tasks.yaml"), std::runtime_error);
}

TEST(CustomTasksTest, ScalarFieldPlotWritesAPngAndRejectsBadInput) {
  const MazeMap map = MazeMap::FromName("medium");
  const std::string path = TmpFile("field.png", "");
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> v;
  for (const Cell& c : map.FreeCells()) {
    xy.push_back(map.CellCenter(c));
    v.push_back(-static_cast<double>(map.BfsDistance(c, {1, 1})));
  }
  SaveScalarFieldPlot(map, xy, v, 4.0, -20, 0, ColorScale::kSequential, {0, 0}, "test", path, 16);
  std::ifstream f(path, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                         std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 100u);
  EXPECT_EQ(bytes[1], 'P');
  EXPECT_THROW(
      SaveScalarFieldPlot(map, xy, {1.0}, 4.0, -20, 0, ColorScale::kSequential, {0, 0}, "", path),
      std::invalid_argument);
  EXPECT_THROW(SaveScalarFieldPlot(map, xy, v, 4.0, 0, 0, ColorScale::kDiverging, {0, 0}, "", path),
               std::invalid_argument);
  EXPECT_THROW(SaveScalarFieldPlot(map, xy, v, 4.0, -1, 1, ColorScale::kDiverging, {0, 0}, "",
                                   "/nonexistent/x.png"),
               std::runtime_error);
}

}  // namespace
}  // namespace msspr::sim
