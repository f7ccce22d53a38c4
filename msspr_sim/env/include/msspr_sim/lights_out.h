// The rule and the evaluation tasks of OGBench's puzzle-3x3 and puzzle-4x4 ("Lights Out"),
// without physics: R x C buttons, each on (1) or off (0); pressing a button toggles it and
// those of its four neighbours that exist (no wrap-around: a corner toggles 3 buttons, an
// edge 4, an inner button 5). Button k = i * cols + j sits in row i (along +x on the
// table) and column j (along +y). Several presses commute, and pressing twice undoes a
// press, so a board is solved by a set of buttons: Solve finds the fewest, over GF(2).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace msspr::sim {

// A board's buttons, 0 or 1, index k = i * cols + j.
using LightsOutState = std::vector<uint8_t>;

class LightsOut {
 public:
  // Throws std::invalid_argument unless 1 <= rows, cols and rows * cols <= 32.
  LightsOut(int rows, int cols);

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int size() const { return rows_ * cols_; }

  // The buttons pressing k toggles (k first, then its neighbours). Throws
  // std::out_of_range for a bad k.
  std::vector<int> Toggled(int k) const;
  // Presses button k of `state` (of size()).
  void Press(int k, LightsOutState* state) const;

  // A set of presses turning `from` into `to` with the fewest buttons, in increasing
  // order; nullopt when no set does. `solutions`, when given, receives how many sets do
  // (0, or 2^(size() - Rank())). Throws std::invalid_argument for states of another size
  // or with values other than 0 and 1.
  std::optional<std::vector<int>> Solve(const LightsOutState& from, const LightsOutState& to,
                                        long* solutions = nullptr) const;
  // The rank over GF(2) of the press matrix: 9 for 3 x 3 (every board solvable), 12 for
  // 4 x 4 (1 in 16 boards).
  int Rank() const;

  // "110/101/011": rows separated by '/', row i's buttons left to right (column 0
  // first). Throws std::invalid_argument naming the text unless it has rows() rows of
  // cols() characters '0' or '1'.
  LightsOutState Parse(const std::string& text) const;
  std::string Format(const LightsOutState& state) const;

 private:
  uint32_t Mask(const LightsOutState& state, const char* what) const;

  int rows_, cols_;
  std::vector<uint32_t> press_;  // press_[k]: the bits pressing k toggles
};

// One of OGBench's puzzle evaluation tasks: the start and goal boards, set exactly.
struct LightsOutTask {
  std::string name;
  LightsOutState start, goal;
};
// The five tasks (task ids 1 to 5 are [0] to [4]) of puzzle-3x3 (side 3) or puzzle-4x4
// (side 4); throws std::invalid_argument for another side.
const std::vector<LightsOutTask>& PuzzleTasks(int side);

}  // namespace msspr::sim
