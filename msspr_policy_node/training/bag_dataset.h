// Reads msspr dataset bags (msspr_collect or `rosbag record` of the live sim)
// into the core's Dataset in one streaming pass per bag. Gaps and dropped
// messages are reported with counts and never bridged: each complete run of
// an episode becomes its own trajectory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "msspr_core/dataset.h"

namespace msspr::ros_bridge {
struct RobotSpec;
}

namespace msspr::agent {

struct BagLoadOptions {
  // Bags of a robot's standard messages read through this spec (spec_bag.h;
  // every episode is "train"); nullptr: msspr dataset bags.
  const ros_bridge::RobotSpec* robot = nullptr;
  // With robot: the namespace its relative topics resolve under ("": the spec's
  // `namespace:`, else the one the recording holds them in; topic_names.h).
  std::string ns;
  std::string split = "train";  // "train", "val", or "" for every episode
  bool images = false;          // load camera images (episodes without them are skipped)
  int min_segment_steps = 2;    // shorter runs (no transition) are dropped
};

struct BagLoadReport {
  std::string env;  // EpisodeInfo.env of the first episode loaded, e.g. "pointmaze-medium"
  uint64_t bags = 0, episodes = 0, episodes_other_split = 0, episodes_without_images = 0;
  uint64_t trajectories = 0, steps = 0;
  uint64_t incomplete_episodes = 0, dropped_steps = 0, short_segments = 0;
  uint64_t missing_observations = 0, missing_actions = 0, missing_images = 0, duplicates = 0;
  std::vector<std::string> problems;  // "BAG: episode 3: missing observations: 2 (steps 4-5)"
  // A robot's bags: per bag, the ticks used and why the others are not (SpecBagReport::usage).
  std::vector<std::string> usage;
  // One line per bag-level fact worth printing (counts), for the trainer's log.
  std::string Summary() const;
};

// Loads the episodes of `options.split` from every bag into one Dataset.
// Throws ros_bridge::BagError naming the bag when it is unreadable, and
// core::DatasetError when the bags disagree on dimensions or hold no data.
core::Dataset LoadBagDataset(const std::vector<std::string>& bags, const BagLoadOptions& options,
                             BagLoadReport* report);

// True for paths ending in ".bag".
bool IsBagPath(const std::string& path);

}  // namespace msspr::agent
