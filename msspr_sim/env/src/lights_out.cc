#include "msspr_sim/lights_out.h"

#include <algorithm>
#include <bitset>
#include <stdexcept>

namespace msspr::sim {

LightsOut::LightsOut(int rows, int cols) : rows_(rows), cols_(cols) {
  if (rows < 1 || cols < 1 || rows * cols > 32)
    throw std::invalid_argument("LightsOut: a board of " + std::to_string(rows) + " x " +
                                std::to_string(cols) + " buttons (1 to 32 buttons)");
  for (int k = 0; k < size(); ++k) {
    uint32_t m = 0;
    for (int t : Toggled(k)) m |= 1u << t;
    press_.push_back(m);
  }
}

std::vector<int> LightsOut::Toggled(int k) const {
  if (k < 0 || k >= size())
    throw std::out_of_range("LightsOut: button " + std::to_string(k) + " of " +
                            std::to_string(size()));
  const int i = k / cols_, j = k % cols_;
  std::vector<int> out{k};
  if (i > 0) out.push_back(k - cols_);
  if (i + 1 < rows_) out.push_back(k + cols_);
  if (j > 0) out.push_back(k - 1);
  if (j + 1 < cols_) out.push_back(k + 1);
  return out;
}

void LightsOut::Press(int k, LightsOutState* state) const {
  Mask(*state, "state");
  for (int t : Toggled(k)) (*state)[t] ^= 1;
}

uint32_t LightsOut::Mask(const LightsOutState& state, const char* what) const {
  if (static_cast<int>(state.size()) != size())
    throw std::invalid_argument(std::string("LightsOut: the ") + what + " has " +
                                std::to_string(state.size()) + " buttons, the board " +
                                std::to_string(size()));
  uint32_t m = 0;
  for (int k = 0; k < size(); ++k) {
    if (state[k] > 1)
      throw std::invalid_argument(std::string("LightsOut: the ") + what + "'s button " +
                                  std::to_string(k) + " is " + std::to_string(state[k]) +
                                  ", not 0 or 1");
    m |= static_cast<uint32_t>(state[k]) << k;
  }
  return m;
}

namespace {

// Gaussian elimination over GF(2) of the system sum_k x_k press[k] = b. Rows are the
// equations (one per button), held as bitmasks of the unknowns plus the right-hand side.
struct Elimination {
  std::vector<int> pivot_col;  // per reduced row, its pivot unknown
  std::vector<uint32_t> rows;  // reduced rows (unknowns)
  std::vector<uint8_t> rhs;    // their right-hand sides
  bool consistent = true;
};

Elimination Eliminate(const std::vector<uint32_t>& press, uint32_t b) {
  const int n = static_cast<int>(press.size());
  // Equation e: sum over k with bit e of press[k] set. The press matrix is symmetric, so
  // equation e's unknowns are press[e]'s bits.
  std::vector<uint32_t> eq(press.begin(), press.end());
  std::vector<uint8_t> rhs(n);
  for (int e = 0; e < n; ++e) rhs[e] = (b >> e) & 1u;
  Elimination out;
  int r = 0;
  for (int c = 0; c < n && r < n; ++c) {
    int p = r;
    while (p < n && !((eq[p] >> c) & 1u)) ++p;
    if (p == n) continue;
    std::swap(eq[p], eq[r]);
    std::swap(rhs[p], rhs[r]);
    for (int e = 0; e < n; ++e) {
      if (e != r && ((eq[e] >> c) & 1u)) {
        eq[e] ^= eq[r];
        rhs[e] ^= rhs[r];
      }
    }
    out.pivot_col.push_back(c);
    ++r;
  }
  for (int e = r; e < n; ++e) out.consistent = out.consistent && rhs[e] == 0;
  out.rows.assign(eq.begin(), eq.begin() + r);
  out.rhs.assign(rhs.begin(), rhs.begin() + r);
  return out;
}

}  // namespace

int LightsOut::Rank() const { return static_cast<int>(Eliminate(press_, 0).rows.size()); }

std::optional<std::vector<int>> LightsOut::Solve(const LightsOutState& from,
                                                 const LightsOutState& to, long* solutions) const {
  const Elimination el = Eliminate(press_, Mask(from, "start") ^ Mask(to, "goal"));
  if (solutions) *solutions = 0;
  if (!el.consistent) return std::nullopt;
  const int n = size();
  std::vector<int> free_cols;
  uint32_t pivots = 0;
  for (int c : el.pivot_col) pivots |= 1u << c;
  for (int c = 0; c < n; ++c)
    if (!((pivots >> c) & 1u)) free_cols.push_back(c);
  const long count = 1L << free_cols.size();
  if (solutions) *solutions = count;
  // Every choice of the free unknowns gives one solution; keep the lightest.
  uint32_t best = 0;
  int best_weight = n + 1;
  for (long choice = 0; choice < count; ++choice) {
    uint32_t x = 0;
    for (size_t f = 0; f < free_cols.size(); ++f)
      if ((choice >> f) & 1L) x |= 1u << free_cols[f];
    for (size_t r = 0; r < el.rows.size(); ++r) {
      const uint32_t others = el.rows[r] & ~(1u << el.pivot_col[r]);
      const uint8_t v = el.rhs[r] ^ (std::bitset<32>(others & x).count() & 1u);
      if (v) x |= 1u << el.pivot_col[r];
    }
    const int w = static_cast<int>(std::bitset<32>(x).count());
    if (w < best_weight) {
      best_weight = w;
      best = x;
    }
  }
  std::vector<int> presses;
  for (int k = 0; k < n; ++k)
    if ((best >> k) & 1u) presses.push_back(k);
  return presses;
}

LightsOutState LightsOut::Parse(const std::string& text) const {
  LightsOutState s;
  int row_len = 0, rows = 1;
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument("LightsOut: '" + text + "' is not a " + std::to_string(rows_) +
                                 " x " + std::to_string(cols_) + " board: " + why);
  };
  for (char ch : text) {
    if (ch == '/') {
      if (row_len != cols_)
        throw bad("row " + std::to_string(rows) + " has " + std::to_string(row_len) + " buttons");
      row_len = 0;
      ++rows;
    } else if (ch == '0' || ch == '1') {
      s.push_back(static_cast<uint8_t>(ch - '0'));
      ++row_len;
    } else {
      throw bad(std::string("'") + ch + "' is not 0, 1 or /");
    }
  }
  if (row_len != cols_)
    throw bad("row " + std::to_string(rows) + " has " + std::to_string(row_len) + " buttons");
  if (rows != rows_) throw bad(std::to_string(rows) + " rows");
  return s;
}

std::string LightsOut::Format(const LightsOutState& state) const {
  Mask(state, "state");
  std::string out;
  for (int k = 0; k < size(); ++k) {
    if (k > 0 && k % cols_ == 0) out.push_back('/');
    out.push_back(static_cast<char>('0' + state[k]));
  }
  return out;
}

namespace {

// Five (start, goal) boards as text, parsed on a side x side board.
std::vector<LightsOutTask> MakeTasks(int side, const char* const (&text)[5][2]) {
  const LightsOut b(side, side);
  std::vector<LightsOutTask> v;
  for (int i = 0; i < 5; ++i)
    v.push_back({"task" + std::to_string(i + 1), b.Parse(text[i][0]), b.Parse(text[i][1])});
  return v;
}

}  // namespace

const std::vector<LightsOutTask>& PuzzleTasks(int side) {
  static const char* const k3_text[5][2] = {{"000/000/000", "110/101/011"},
                                            {"111/111/111", "011/111/111"},
                                            {"010/111/010", "101/010/101"},
                                            {"010/101/010", "111/111/111"},
                                            {"111/111/111", "101/101/101"}};
  static const char* const k4_text[5][2] = {{"0000/0000/0000/0000", "1111/1111/1111/1111"},
                                            {"1111/1111/1111/1111", "1111/1001/1001/1111"},
                                            {"1000/0000/0000/0001", "0101/1010/0101/1010"},
                                            {"1001/1001/1001/1001", "0000/0000/0000/0000"},
                                            {"0101/0010/0001/1000", "0000/0000/0000/0000"}};
  static const std::vector<LightsOutTask> k3 = MakeTasks(3, k3_text);
  static const std::vector<LightsOutTask> k4 = MakeTasks(4, k4_text);
  if (side == 3) return k3;
  if (side == 4) return k4;
  throw std::invalid_argument("PuzzleTasks: puzzle-" + std::to_string(side) + "x" +
                              std::to_string(side) + " is not one of OGBench's (3 or 4)");
}

}  // namespace msspr::sim
