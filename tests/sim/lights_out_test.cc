// The Lights Out rule and OGBench's puzzle-3x3 and puzzle-4x4 evaluation tasks: what each
// press toggles, the press matrix's rank, the fewest presses that solve each task (and that
// they do solve it), and boards that cannot be solved.
#include "msspr_sim/lights_out.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

namespace msspr::sim {
namespace {

LightsOutState Apply(const LightsOut& b, LightsOutState s, const std::vector<int>& presses) {
  for (int k : presses) b.Press(k, &s);
  return s;
}

TEST(LightsOut, CornersToggleThreeEdgesFourInnerButtonsFive) {
  const LightsOut b(3, 3);
  EXPECT_EQ(b.Toggled(0), (std::vector<int>{0, 3, 1}));
  EXPECT_EQ(b.Toggled(1).size(), 4u);
  EXPECT_EQ(b.Toggled(4), (std::vector<int>{4, 1, 7, 3, 5}));
  EXPECT_EQ(b.Toggled(8).size(), 3u);
  const LightsOut b4(4, 4);
  int corners = 0, edges = 0, inner = 0;
  for (int k = 0; k < b4.size(); ++k) {
    const size_t n = b4.Toggled(k).size();
    corners += n == 3;
    edges += n == 4;
    inner += n == 5;
  }
  EXPECT_EQ(corners, 4);
  EXPECT_EQ(edges, 8);
  EXPECT_EQ(inner, 4);
  EXPECT_THROW(b.Toggled(9), std::out_of_range);
  // Pressing twice undoes a press.
  LightsOutState s = b.Parse("010/111/010");
  b.Press(4, &s);
  EXPECT_EQ(b.Format(s), "000/000/000");
  b.Press(4, &s);
  EXPECT_EQ(b.Format(s), "010/111/010");
}

TEST(LightsOut, ThreeByThreeIsInvertibleFourByFourHasRankTwelve) {
  EXPECT_EQ(LightsOut(3, 3).Rank(), 9);
  EXPECT_EQ(LightsOut(4, 4).Rank(), 12);
  // So exactly 2^12 of the 2^16 differences between two 4 x 4 boards can be pressed away.
  const LightsOut b(4, 4);
  const LightsOutState zero(16, 0);
  int solvable = 0;
  for (uint32_t m = 0; m < (1u << 16); ++m) {
    LightsOutState s(16);
    for (int k = 0; k < 16; ++k) s[k] = (m >> k) & 1u;
    solvable += b.Solve(s, zero).has_value();
  }
  EXPECT_EQ(solvable, 4096);
}

// OGBench's five tasks of each size: every one solvable; the fewest presses 2, 5, 8, 9, 7
// (3 x 3, one press set each) and 4, 6, 6, 6, 7 (4 x 4, 16 press sets each).
TEST(LightsOut, EveryEvaluationTaskIsSolvedByItsFewestPresses) {
  const std::vector<std::pair<int, std::vector<size_t>>> expected = {{3, {2, 5, 8, 9, 7}},
                                                                     {4, {4, 6, 6, 6, 7}}};
  for (const auto& [side, fewest] : expected) {
    const LightsOut b(side, side);
    const auto& tasks = PuzzleTasks(side);
    ASSERT_EQ(tasks.size(), 5u);
    for (size_t t = 0; t < tasks.size(); ++t) {
      long count = -1;
      const auto presses = b.Solve(tasks[t].start, tasks[t].goal, &count);
      ASSERT_TRUE(presses.has_value()) << side << "x" << side << " task " << t + 1;
      EXPECT_EQ(presses->size(), fewest[t]) << side << "x" << side << " task " << t + 1;
      EXPECT_EQ(count, side == 3 ? 1 : 16);
      EXPECT_EQ(Apply(b, tasks[t].start, *presses), tasks[t].goal)
          << side << "x" << side << " task " << t + 1;
    }
  }
  EXPECT_EQ(LightsOut(3, 3).Format(PuzzleTasks(3)[0].goal), "110/101/011");
  EXPECT_EQ(LightsOut(4, 4).Format(PuzzleTasks(4)[2].start), "1000/0000/0000/0001");
  EXPECT_THROW(PuzzleTasks(5), std::invalid_argument);
}

// On random boards (seeded) the solution solves and no lighter press set does: checked by
// trying every set of fewer presses on the 3 x 3 board.
TEST(LightsOut, SolutionsOfRandomBoardsSolveAndAreLightest) {
  std::mt19937 rng(7);
  const LightsOut b(3, 3);
  for (int trial = 0; trial < 50; ++trial) {
    LightsOutState from(9), to(9);
    for (int k = 0; k < 9; ++k) {
      from[k] = rng() & 1u;
      to[k] = rng() & 1u;
    }
    const auto presses = b.Solve(from, to);
    ASSERT_TRUE(presses.has_value());
    EXPECT_EQ(Apply(b, from, *presses), to);
    for (uint32_t m = 0; m < 512; ++m) {
      std::vector<int> set;
      for (int k = 0; k < 9; ++k)
        if ((m >> k) & 1u) set.push_back(k);
      if (set.size() < presses->size()) {
        EXPECT_NE(Apply(b, from, set), to) << "a lighter set solves trial " << trial;
      }
    }
  }
  // A 4 x 4 difference outside the press matrix's span: no solution, 0 sets.
  const LightsOut b4(4, 4);
  LightsOutState one(16, 0);
  one[0] = 1;
  long count = -1;
  EXPECT_FALSE(b4.Solve(one, LightsOutState(16, 0), &count).has_value());
  EXPECT_EQ(count, 0);
}

TEST(LightsOut, BadBoardsAreRejectedNamingWhatIsWrong) {
  const LightsOut b(3, 3);
  auto message = [&](const std::string& text) {
    try {
      b.Parse(text);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("110/101").find("2 rows"), std::string::npos) << message("110/101");
  EXPECT_NE(message("110/10/011").find("row 2 has 2 buttons"), std::string::npos);
  EXPECT_NE(message("110/1x1/011").find("'x' is not 0, 1 or /"), std::string::npos);
  EXPECT_THROW(b.Solve(LightsOutState(8, 0), LightsOutState(9, 0)), std::invalid_argument);
  EXPECT_THROW(b.Solve(LightsOutState(9, 2), LightsOutState(9, 0)), std::invalid_argument);
  EXPECT_THROW(LightsOut(0, 3), std::invalid_argument);
  EXPECT_THROW(LightsOut(6, 6), std::invalid_argument);
}

}  // namespace
}  // namespace msspr::sim
