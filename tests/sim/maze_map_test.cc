#include "msspr_sim/maze_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::sim {
namespace {

// OGBench's maps, rows top to bottom.
const std::vector<std::string> kMedium = {"11111111", "10011001", "10010001", "11000111",
                                          "10010001", "10100101", "10001001", "11111111"};
const std::vector<std::string> kLarge = {"111111111111", "100001000001", "101101010101",
                                         "100000010001", "101111011101", "100101000001",
                                         "110101010111", "100100010001", "111111111111"};
const std::vector<std::string> kGiant = {
    "1111111111111111", "1010000001100001", "1010110101001101", "1000100100010001",
    "1011101111110101", "1000100010000101", "1110101001010111", "1000100100010001",
    "1010101111110101", "1011100010001101", "1000001000100001", "1111111111111111"};

void ExpectMapEquals(const MazeMap& map, const std::vector<std::string>& rows) {
  ASSERT_EQ(map.rows(), static_cast<int>(rows.size()));
  ASSERT_EQ(map.cols(), static_cast<int>(rows[0].size()));
  for (int i = 0; i < map.rows(); ++i) {
    for (int j = 0; j < map.cols(); ++j) {
      EXPECT_EQ(map.IsWall({i, j}), rows[i][j] == '1') << map.name() << " cell " << i << "," << j;
    }
  }
}

TEST(MazeMapTest, MapsMatchBenchmark) {
  ExpectMapEquals(MazeMap::FromName("medium"), kMedium);
  ExpectMapEquals(MazeMap::FromName("large"), kLarge);
  ExpectMapEquals(MazeMap::FromName("giant"), kGiant);
  std::vector<std::string> arena(8, "10000001");
  arena.front() = arena.back() = "11111111";
  ExpectMapEquals(MazeMap::FromName("arena"), arena);
}

TEST(MazeMapTest, NamesAndBadName) {
  EXPECT_EQ(MazeMap::Names(), (std::vector<std::string>{"arena", "medium", "large", "giant"}));
  for (const std::string& n : MazeMap::Names()) EXPECT_EQ(MazeMap::FromName(n).name(), n);
  try {
    MazeMap::FromName("huge");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("huge"), std::string::npos) << msg;
    for (const std::string& n : MazeMap::Names()) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

TEST(MazeMapTest, OutsideIsWall) {
  const MazeMap m = MazeMap::FromName("medium");
  EXPECT_TRUE(m.IsWall({-1, 1}));
  EXPECT_TRUE(m.IsWall({1, -1}));
  EXPECT_TRUE(m.IsWall({8, 1}));
  EXPECT_TRUE(m.IsWall({1, 8}));
  EXPECT_FALSE(m.IsWall({1, 1}));
}

TEST(MazeMapTest, CellCenterAndXYToCell) {
  const MazeMap m = MazeMap::FromName("large");
  EXPECT_EQ(m.CellCenter({1, 1}), Eigen::Vector2d(0, 0));
  EXPECT_EQ(m.CellCenter({7, 10}), Eigen::Vector2d(36, 24));  // x = 4j - 4, y = 4i - 4
  EXPECT_EQ(m.CellCenter({0, 0}), Eigen::Vector2d(-4, -4));
  for (int i = 0; i < m.rows(); ++i) {
    for (int j = 0; j < m.cols(); ++j) {
      const Eigen::Vector2d c = m.CellCenter({i, j});
      EXPECT_EQ(m.XYToCell(c), (Cell{i, j}));
      EXPECT_EQ(m.XYToCell(c + Eigen::Vector2d(1.9, -1.9)), (Cell{i, j}));
      EXPECT_EQ(m.XYToCell(c + Eigen::Vector2d(2.1, 0)), (Cell{i, j + 1}));
      EXPECT_EQ(m.XYToCell(c + Eigen::Vector2d(0, -2.1)), (Cell{i - 1, j}));
    }
  }
}

struct TaskSpec {
  int si, sj, gi, gj;
};

void ExpectTasks(const std::string& name, const std::vector<TaskSpec>& want) {
  const MazeMap m = MazeMap::FromName(name);
  ASSERT_EQ(m.Tasks().size(), want.size()) << name;
  for (size_t k = 0; k < want.size(); ++k) {
    const MazeMap::Task& t = m.Tasks()[k];
    EXPECT_EQ(t.id, static_cast<int>(k) + 1);
    EXPECT_EQ(t.start, (Cell{want[k].si, want[k].sj})) << name << " task " << t.id;
    EXPECT_EQ(t.goal, (Cell{want[k].gi, want[k].gj})) << name << " task " << t.id;
    EXPECT_FALSE(m.IsWall(t.start));
    EXPECT_FALSE(m.IsWall(t.goal));
    EXPECT_GT(m.BfsDistance(t.start, t.goal), 0);
  }
}

TEST(MazeMapTest, TasksMatchBenchmark) {
  ExpectTasks("medium", {{1, 1, 6, 6}, {6, 1, 1, 6}, {5, 3, 4, 2}, {6, 5, 6, 1}, {2, 6, 1, 1}});
  ExpectTasks("large", {{1, 1, 7, 10}, {5, 4, 7, 1}, {7, 4, 1, 10}, {3, 8, 5, 4}, {1, 1, 5, 4}});
  ExpectTasks("giant",
              {{1, 1, 10, 14}, {1, 14, 10, 1}, {8, 14, 1, 1}, {8, 3, 5, 12}, {5, 9, 3, 8}});
  // Arena tasks are this project's own corner-to-corner tasks.
  ExpectTasks("arena", {{1, 1, 6, 6}, {6, 1, 1, 6}, {6, 6, 1, 1}, {1, 6, 6, 1}, {1, 1, 6, 1}});
}

TEST(MazeMapTest, TaskByIdFindsTheTaskOrNamesTheValidIds) {
  const MazeMap map = MazeMap::FromName("large");
  for (const MazeMap::Task& t : map.Tasks()) EXPECT_EQ(&map.TaskById(t.id, "caller"), &t);
  for (int bad : {0, 6}) {
    try {
      map.TaskById(bad, "Env::ResetToTask");
      ADD_FAILURE() << "task " << bad << " was found";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()), "Env::ResetToTask: no task " + std::to_string(bad) +
                                           " in maze large (valid: 1..5)");
    }
  }
}

TEST(MazeMapTest, FreeAndVertexCells) {
  const MazeMap m = MazeMap::FromName("medium");
  int free_count = 0;
  for (const std::string& row : kMedium) free_count += std::count(row.begin(), row.end(), '0');
  EXPECT_EQ(static_cast<int>(m.FreeCells().size()), free_count);
  const std::vector<Cell> v = m.VertexCells();
  const auto has = [&](Cell c) { return std::find(v.begin(), v.end(), c) != v.end(); };
  EXPECT_FALSE(has({3, 3}));  // left-right hallway
  EXPECT_TRUE(has({1, 1}));   // corner
  EXPECT_TRUE(has({3, 2}));   // turn / junction
  EXPECT_FALSE(has({0, 0}));  // wall
  for (const Cell& c : v) EXPECT_FALSE(m.IsWall(c));
  // Arena has no hallway cells.
  const MazeMap arena = MazeMap::FromName("arena");
  EXPECT_EQ(arena.VertexCells().size(), arena.FreeCells().size());
}

// All-pairs distances by Floyd-Warshall, independent of the BFS.
std::vector<std::vector<int>> FloydWarshall(const MazeMap& m) {
  const int n = m.rows() * m.cols();
  const int inf = 1 << 20;
  std::vector<std::vector<int>> d(n, std::vector<int>(n, inf));
  for (int a = 0; a < n; ++a) {
    const Cell ca{a / m.cols(), a % m.cols()};
    if (m.IsWall(ca)) continue;
    d[a][a] = 0;
    for (int b = 0; b < n; ++b) {
      const Cell cb{b / m.cols(), b % m.cols()};
      if (!m.IsWall(cb) && std::abs(ca.i - cb.i) + std::abs(ca.j - cb.j) == 1) d[a][b] = 1;
    }
  }
  for (int k = 0; k < n; ++k) {
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) d[a][b] = std::min(d[a][b], d[a][k] + d[k][b]);
    }
  }
  for (auto& row : d) {
    for (int& x : row) x = x >= inf ? -1 : x;
  }
  return d;
}

TEST(MazeMapTest, BfsMatchesFloydWarshallAndPathsAreShortest) {
  for (const std::string name : {"medium", "large", "giant"}) {
    const MazeMap m = MazeMap::FromName(name);
    const auto fw = FloydWarshall(m);
    const int n = m.rows() * m.cols();
    int paths_checked = 0;
    for (int a = 0; a < n; ++a) {
      const Cell ca{a / m.cols(), a % m.cols()};
      const std::vector<int> all = m.BfsDistances(ca);
      for (int b = 0; b < n; ++b) {
        const Cell cb{b / m.cols(), b % m.cols()};
        ASSERT_EQ(all[b], fw[a][b]) << name;
        if (name == "giant") continue;  // paths: medium and large are enough
        ASSERT_EQ(m.BfsDistance(ca, cb), fw[a][b]) << name;
        const std::vector<Cell> path = m.ShortestPath(ca, cb);
        if (fw[a][b] < 0) {
          ASSERT_TRUE(path.empty());
          continue;
        }
        ASSERT_EQ(static_cast<int>(path.size()), fw[a][b] + 1);
        ASSERT_EQ(path.front(), ca);
        ASSERT_EQ(path.back(), cb);
        ++paths_checked;
        for (size_t k = 0; k < path.size(); ++k) {
          ASSERT_FALSE(m.IsWall(path[k]));
          if (k > 0) {
            ASSERT_EQ(std::abs(path[k].i - path[k - 1].i) + std::abs(path[k].j - path[k - 1].j), 1);
          }
        }
      }
    }
    std::printf("[ INFO ] %s: %d shortest paths checked\n", name.c_str(), paths_checked);
    if (name != "giant") {
      EXPECT_EQ(paths_checked, static_cast<int>(m.FreeCells().size() * m.FreeCells().size()));
    }
  }
}

TEST(MazeMapTest, EveryFreeCellIsReachable) {
  for (const std::string& name : MazeMap::Names()) {
    const MazeMap m = MazeMap::FromName(name);
    const std::vector<Cell> free = m.FreeCells();
    for (const Cell& c : free) EXPECT_GE(m.BfsDistance(free.front(), c), 0) << name;
  }
}

TEST(MazeMapTest, MjcfHasTheParts) {
  const std::string xml = MazeMap::FromName("medium").ToMjcf(96);
  EXPECT_NE(xml.find("autolimits=\"true\""), std::string::npos);
  EXPECT_NE(xml.find("offwidth=\"96\""), std::string::npos);
  EXPECT_NE(xml.find("integrator=\"RK4\""), std::string::npos);
  EXPECT_NE(xml.find("timestep=\"0.02\""), std::string::npos);
  EXPECT_NE(xml.find("name=\"track\""), std::string::npos);
  EXPECT_NE(xml.find("size=\"0.7\""), std::string::npos);
  EXPECT_NE(xml.find("class=\"tile\""), std::string::npos);
}

}  // namespace
}  // namespace msspr::sim
