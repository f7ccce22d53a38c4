// Commands without stamps (geometry_msgs/Twist, std_msgs/Float64MultiArray)
// counted for their own control ticks. A controller that publishes one command
// per control period sends each some latency after its tick, and the recording
// receives it with jitter: taking "the newest command received before the next
// tick" gives a tick the next tick's command whenever that one arrives early.
// AlignCommands instead finds where in the period the commands of a recording
// fall (their phase: the circular mean of the receive times modulo the period,
// taken in [-period / 4, 3 period / 4) after the tick), and counts each command for
// the tick whose phase it is nearest. Where two commands fall on one tick, the
// first moves to the tick before when no command came for that one (it arrived
// late), or the last to the tick after (it arrived early); the order received is
// kept, one command per tick, and what cannot move is dropped. A command arriving
// more than a quarter period off the recording's phase is ambiguous and counted.
// No ROS header.
#pragma once

#include <cstdint>
#include <vector>

namespace msspr::ros_bridge {

struct CommandAlignment {
  double phase = 0;        // s after the tick at which the commands arrive (latency)
  double spread = 0;       // s: the largest distance of a command from that phase
  uint64_t commands = 0;   // commands inside the episode's ticks
  uint64_t ambiguous = 0;  // more than a quarter period off the phase
  uint64_t shifted = 0;    // moved to a neighbouring free tick to keep one command per tick
  uint64_t dropped = 0;    // no free tick beside theirs (more commands than ticks)
  // Per tick: the index into the receive times of its command, or -1 (none arrived for it).
  std::vector<int64_t> command_of_tick;
};

// receipts: the commands' receive times (s), ascending; the ticks are begin + k * period,
// k = 0 .. ticks - 1. Commands received before begin - period / 4 or after the last
// tick's period are outside the episode and ignored.
CommandAlignment AlignCommands(const std::vector<double>& receipts, double begin, double period,
                               int64_t ticks);

}  // namespace msspr::ros_bridge
