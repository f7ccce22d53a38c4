// AlignCommands (command_alignment.h): commands without stamps, one per control
// period, sent some latency after their tick and received with jitter, are
// counted for their own ticks.
#include "msspr_robot_interface/command_alignment.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace msspr::ros_bridge {
namespace {

// Receive times of the commands of `ticks` ticks of `period` s from `begin`: command k is
// sent `latency` s after tick k and received with uniform jitter in [-jitter, jitter].
// Receive order may differ from send order (a late one overtaken by the next): sorted, as a
// bag stores them, with `sent_for` telling which tick each was sent for.
std::vector<double> Receipts(int ticks, double begin, double period, double latency, double jitter,
                             uint32_t seed, std::vector<int>* sent_for) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  std::vector<std::pair<double, int>> r;
  for (int k = 0; k < ticks; ++k) r.emplace_back(begin + k * period + latency + u(rng), k);
  std::sort(r.begin(), r.end());
  std::vector<double> out;
  sent_for->clear();
  for (const auto& [t, k] : r) {
    out.push_back(t);
    sent_for->push_back(k);
  }
  return out;
}

// Ticks that got no command or another tick's command.
int WrongTicks(const CommandAlignment& a, const std::vector<int>& sent_for) {
  int wrong = 0;
  for (size_t k = 0; k < a.command_of_tick.size(); ++k) {
    const int64_t j = a.command_of_tick[k];
    if (j < 0 || sent_for[static_cast<size_t>(j)] != static_cast<int>(k)) ++wrong;
  }
  return wrong;
}

TEST(CommandAlignment, EachCommandCountsForItsOwnTickUnderLatencyAndJitter) {
  const double period = 0.1;
  const int ticks = 2000;
  for (double latency : {0.0, 0.01, 0.03, 0.05}) {
    for (double jitter : {0.0, 0.01, 0.02}) {
      std::vector<int> sent_for;
      const auto r = Receipts(ticks, 100.0, period, latency, jitter, 7, &sent_for);
      const CommandAlignment a = AlignCommands(r, 100.0, period, ticks);
      const int wrong = WrongTicks(a, sent_for);
      EXPECT_LE(wrong, ticks / 100) << "latency " << latency << " jitter " << jitter;
      EXPECT_NEAR(a.phase, latency, 0.005) << "latency " << latency << " jitter " << jitter;
      EXPECT_EQ(a.commands, static_cast<uint64_t>(ticks));
      EXPECT_EQ(a.ambiguous, 0u);
      EXPECT_LE(a.spread, jitter + 0.005);
    }
  }
}

TEST(CommandAlignment, TheNewestBeforeTheNextTickRuleWouldMisassignTheSameRecording) {
  // The rule this replaces (the newest command received before the next tick) on 10 ms
  // latency and +-20 ms jitter: a tick takes the next command whenever it arrives early.
  const double period = 0.1;
  const int ticks = 2000;
  std::vector<int> sent_for;
  const auto r = Receipts(ticks, 0.0, period, 0.01, 0.02, 11, &sent_for);
  int old_wrong = 0;
  for (int k = 0; k < ticks; ++k) {
    const double next = (k + 1) * period;
    int newest = -1;
    for (size_t j = 0; j < r.size() && r[j] < next; ++j) newest = static_cast<int>(j);
    if (newest < 0 || sent_for[static_cast<size_t>(newest)] != k) ++old_wrong;
  }
  EXPECT_GT(old_wrong, ticks / 20);  // about 12%
  EXPECT_LE(WrongTicks(AlignCommands(r, 0.0, period, ticks), sent_for), ticks / 100);
}

TEST(CommandAlignment, DroppedCommandsLeaveTheirTicksEmptyAndOffPhaseOnesAreCounted) {
  const double period = 0.1;
  std::vector<double> r;
  for (int k = 0; k < 10; ++k)
    if (k != 4) r.push_back(k * period + 0.01);
  r.push_back(9 * period + 0.05);  // a second command in tick 9, 40 ms off the phase
  std::sort(r.begin(), r.end());
  const CommandAlignment a = AlignCommands(r, 0.0, period, 10);
  EXPECT_EQ(a.command_of_tick[4], -1);
  EXPECT_EQ(a.command_of_tick[3], 3);
  EXPECT_EQ(a.command_of_tick[5], 4);
  EXPECT_EQ(a.ambiguous, 1u);
  EXPECT_EQ(a.dropped, 1u);  // no tick after the last for the extra command
  EXPECT_NEAR(a.phase, 0.01, 0.01);
}

TEST(CommandAlignment, CommandsOutsideTheEpisodeAreIgnored) {
  const std::vector<double> r = {-1.0, 0.0, 0.1, 0.2, 5.0};
  const CommandAlignment a = AlignCommands(r, 0.0, 0.1, 3);
  EXPECT_EQ(a.commands, 3u);
  EXPECT_EQ(a.command_of_tick, (std::vector<int64_t>{1, 2, 3}));
  EXPECT_TRUE(AlignCommands({}, 0.0, 0.1, 3).command_of_tick == std::vector<int64_t>(3, -1));
}

}  // namespace
}  // namespace msspr::ros_bridge
