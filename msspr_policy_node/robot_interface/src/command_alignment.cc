#include "msspr_robot_interface/command_alignment.h"

#include <algorithm>
#include <cmath>

namespace msspr::ros_bridge {

CommandAlignment AlignCommands(const std::vector<double>& receipts, double begin, double period,
                               int64_t ticks) {
  CommandAlignment a;
  a.command_of_tick.assign(static_cast<size_t>(std::max<int64_t>(ticks, 0)), -1);
  if (ticks <= 0 || !(period > 0)) return a;
  const double lo = begin - period / 4, hi = begin + (static_cast<double>(ticks) - 0.25) * period;
  // The phase: the circular mean of (receipt - begin) modulo the period.
  double sx = 0, sy = 0;
  std::vector<size_t> inside;
  for (size_t j = 0; j < receipts.size(); ++j) {
    if (receipts[j] < lo || receipts[j] >= hi) continue;
    inside.push_back(j);
    const double angle = 2 * M_PI * (receipts[j] - begin) / period;
    sx += std::cos(angle);
    sy += std::sin(angle);
  }
  a.commands = inside.size();
  if (inside.empty()) return a;
  double phase = std::atan2(sy, sx) / (2 * M_PI) * period;  // (-period / 2, period / 2]
  if (phase < -period / 4) phase += period;                 // [-period / 4, 3 period / 4)
  a.phase = phase;
  // Each command's nearest tick at the phase (monotone in the receive order).
  std::vector<std::vector<size_t>> at(static_cast<size_t>(ticks));  // tick -> commands
  for (size_t j : inside) {
    const double x = (receipts[j] - begin - phase) / period;
    const int64_t k = std::clamp<int64_t>(std::llround(x), 0, ticks - 1);
    const double off = std::fabs(x - static_cast<double>(k)) * period;
    a.spread = std::max(a.spread, std::min(off, period / 2));
    if (off > period / 4) ++a.ambiguous;
    at[static_cast<size_t>(k)].push_back(j);
  }
  // Two commands for one tick: the first moves to the tick before when none came for it (it
  // arrived late), the last to the tick after when none came for that one (it arrived early);
  // one per tick, in the order received. What cannot move is dropped.
  for (int64_t k = 0; k < ticks; ++k) {
    std::vector<size_t>& here = at[static_cast<size_t>(k)];
    if (here.size() > 1 && k > 0 && at[static_cast<size_t>(k - 1)].empty() &&
        a.command_of_tick[static_cast<size_t>(k - 1)] < 0) {
      a.command_of_tick[static_cast<size_t>(k - 1)] = static_cast<int64_t>(here.front());
      here.erase(here.begin());
      ++a.shifted;
    }
    if (here.size() > 1 && k + 1 < ticks && at[static_cast<size_t>(k + 1)].empty()) {
      at[static_cast<size_t>(k + 1)].push_back(here.back());
      here.pop_back();
      ++a.shifted;
    }
    if (here.empty()) continue;
    a.dropped += here.size() - 1;
    // Of several, the one nearest the phase stays.
    size_t best = here[0];
    double best_off = 1e300;
    for (size_t j : here) {
      const double x = (receipts[j] - begin - phase) / period;
      const double off = std::fabs(x - static_cast<double>(k));
      if (off < best_off) best = j, best_off = off;
    }
    a.command_of_tick[static_cast<size_t>(k)] = static_cast<int64_t>(best);
  }
  return a;
}

}  // namespace msspr::ros_bridge
