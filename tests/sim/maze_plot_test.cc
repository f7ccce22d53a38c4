#include "msspr_sim/maze_plot.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "msspr_sim/learning_curve.h"

namespace msspr::sim {
namespace {

uint32_t BigEndian(const std::vector<unsigned char>& b, size_t at) {
  return (uint32_t{b[at]} << 24) | (uint32_t{b[at + 1]} << 16) | (uint32_t{b[at + 2]} << 8) |
         b[at + 3];
}

TEST(MazePlotTest, WritesAPngOfTheMapSize) {
  const std::filesystem::path dir = MSSPR_TEST_TMPDIR;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "plot_test.png").string();
  std::remove(path.c_str());
  const MazeMap m = MazeMap::FromName("large");
  SaveTrajectoryPlot(m, {{{0, 0}, {4, 0}, {4, 8}}, {{0, 0}, {0, 4}}}, {{{0, 0}, {4, 8}}},
                     {true, false}, path, 20);
  std::ifstream f(path, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                         std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 24u);
  EXPECT_EQ(bytes[1], 'P');
  EXPECT_EQ(bytes[2], 'N');
  EXPECT_EQ(bytes[3], 'G');
  EXPECT_EQ(BigEndian(bytes, 16), 12u * 20);  // width = cols * pixels_per_cell
  EXPECT_EQ(BigEndian(bytes, 20), 9u * 20);   // height = rows * pixels_per_cell
  EXPECT_THROW(SaveTrajectoryPlot(m, {}, {}, {}, "/nonexistent_dir/x.png"), std::runtime_error);
}

TEST(LearningCurveTest, DrawsTheCsvsOfARunAndRejectsABadRow) {
  const std::filesystem::path dir = std::filesystem::path(MSSPR_TEST_TMPDIR) / "curve";
  std::filesystem::create_directories(dir);
  const std::string eval = (dir / "eval.csv").string(), metrics = (dir / "metrics.csv").string();
  const std::string png = (dir / "learning_curve.png").string();
  std::remove(png.c_str());
  // Nothing logged yet: nothing drawn.
  std::remove(eval.c_str());
  std::remove(metrics.c_str());
  EXPECT_FALSE(SaveLearningCurvePlot(eval, metrics, png));
  EXPECT_FALSE(std::filesystem::exists(png));
  std::ofstream(eval)
      << "step,name,value\n10,val_critic,1.5\n10,success_task1,0.2\n10,mean_success,0.1\n"
      << "20,success_task1,0.6\n20,mean_success,0.4\n";
  std::ofstream(metrics) << "step,wall_s,repr,critic\n1,0.1,5,nan\n2,0.2,4.5,2.25\n20,2,0.5,0.01\n";
  ASSERT_TRUE(SaveLearningCurvePlot(eval, metrics, png));
  std::ifstream f(png, std::ios::binary);
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                         std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 24u);
  EXPECT_EQ(bytes[1], 'P');
  EXPECT_EQ(BigEndian(bytes, 16), 760u);  // width
  EXPECT_FALSE(std::filesystem::exists(png + ".tmp.png"));
  // A malformed row names the file and its line.
  std::ofstream(eval, std::ios::app) << "30,mean_success\n";
  try {
    SaveLearningCurvePlot(eval, metrics, png);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(eval + ":7"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace msspr::sim
