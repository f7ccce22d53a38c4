#include "msspr_sim/maze_plot.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

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

}  // namespace
}  // namespace msspr::sim
