// Training data from a robot's own bags through a robot spec (robot_spec.h):
// the spec's observation, command and episode topics are read, the
// observation and action are sampled at the spec's control rate
// (robot_fields.h: SampleObservation / SampleAction), and each episode comes
// out as a BagEpisode (dataset_bag.h), so that the training adapter treats it
// as it treats msspr's own dataset bags. A spec with images fills the
// episodes' images (decoded and resized by robot_fields.h DecodeImage, as the
// policy node does when serving); bad images are rejected and counted. Ticks
// whose inputs are missing or stale are absent and split the episode (never
// bridged). A pose or observation goal whose topic the bags hold is recorded
// too: each episode's goals hold the goal in effect at each tick (for the
// export; training relabels goals from the trajectories and needs none).
#pragma once

#include <ros/time.h>

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "msspr_bags/dataset_bag.h"
#include "msspr_robot_interface/robot_spec.h"

namespace msspr::ros_bridge {

// What a spec extracts from a bag, per observation field, per camera (its
// images) and per command topic (named action or action:TOPIC), and in total
// (msspr_bag_info --robot).
struct SpecFieldReport {
  std::string name, topic, type;
  uint64_t messages = 0;       // decoded messages on the topic
  double first = 0, last = 0;  // stamps, s
  double rate_hz = 0;          // (messages - 1) / (last - first)
  uint64_t gaps = 0;           // consecutive stamps further apart than stale_after
  double max_gap_s = 0;
  uint64_t ticks = 0, covered_ticks = 0, stale_ticks = 0;  // control ticks of the episodes
  uint64_t late = 0;          // received more than stale_after after their stamp
  uint64_t out_of_order = 0;  // stamped before the message received before them (dropped)
  uint64_t nonfinite = 0;     // NaN / Inf values: message rejected
  uint64_t unreadable = 0;    // a joint or index the message lacks: message rejected
  uint64_t bad_images = 0;    // cameras: undecodable, a wrong encoding or size: image rejected
  bool image = false;         // a camera's row
  std::string first_problem;  // the first of those, with its stamp
  // Command topics without stamps (command_alignment.h): where their commands arrive
  // after the ticks, commands-weighted over the episodes, and how many were ambiguous.
  bool aligned = false;
  double phase_s = 0, spread_s = 0;
  uint64_t aligned_commands = 0, ambiguous = 0, shifted = 0, dropped = 0;
  double coverage() const { return ticks ? static_cast<double>(covered_ticks) / ticks : 0.0; }
};

struct SpecBagReport {
  uint64_t bags = 0;  // read as one recording
  uint64_t episodes = 0, ticks = 0, complete_ticks = 0;
  uint64_t latched_repeats = 0;  // episode messages repeated at the start of a split file
  // One line per bag: its ticks in episodes, the complete ones, and why the others are not
  // used; and the observations before the first episode message.
  std::vector<std::string> usage;
  std::vector<SpecFieldReport> fields;  // observation fields, then the cameras, then the commands
  std::vector<std::string> problems;    // "BAG: topic odom (field 'position'): ..."
};

// Reads bags of standard messages through a spec. Bags that follow each other
// in time are one recording, read in time order as `rosbag play a.bag b.bag`
// plays them (`rosbag record --split` files; bags that overlap in time are
// separate recordings): an episode that crosses files is joined, and the episode
// message that `--repeat-latched` repeats at the start of a file starts no
// episode. One pass per bag; memory holds the decoded numbers of the recording.
// Every bag's structure is checked first (CheckBagStructure: none, lz4 and bz2 chunks).
class SpecBagReader {
 public:
  SpecBagReader(RobotSpec spec, std::vector<std::string> bags);
  ~SpecBagReader();

  // Calls fn for each episode (split "train", episode ids counting from 0). Throws BagError naming
  // the bag, the topic and the field when a bag cannot be read, lacks a topic of the spec, or holds
  // it with another message type.
  void ForEachEpisode(const std::function<void(BagEpisode&&)>& fn);
  const SpecBagReport& report() const { return report_; }
  const RobotSpec& spec() const { return spec_; }
  // Messages on the spec's observation topics in all bags (an upper bound for reserving).
  uint64_t CountObservations() const;
  // The namespace the spec's relative topics resolve under (topic_names.h): the
  // spec's `namespace:` unless set here (--ns); "" infers it from each bag.
  void set_namespace(const std::string& ns) { ns_ = ns; }

 private:
  struct Recording;      // the decoded messages of every bag (spec_bag_recording.h)
  class MessagePass;     // one bag's messages into the recording (spec_bag.cc)
  class EpisodeSampler;  // a recording's episodes at the ticks (spec_bag_episodes.cc)
  // The bag topics of the spec's topics in one bag, resolved under the namespace.
  struct BagTopics {
    std::vector<std::string> obs;  // per layout topic ("" for tf2 fields)
    std::vector<std::string> commands, images;
    std::string tf, tf_static, episode, episode_type;
    std::string goal;  // a vector goal's topic when the bag holds it ("" otherwise)
  };
  BagTopics ResolveTopics(const std::string& path,
                          const std::map<std::string, std::string>& bag_topics,
                          const Recording& rec) const;
  void ReadMessages(const std::string& path, bool first_bag, Recording* rec);
  void AddFieldProblems(const std::string& path, const std::vector<SpecFieldReport>& before);
  std::vector<std::pair<ros::Time, ros::Time>> EpisodeSpans(Recording* rec);
  void EmitEpisodes(Recording* rec, uint64_t* next_id, const std::function<void(BagEpisode&&)>& fn);

  RobotSpec spec_;
  std::vector<std::string> bags_;
  std::string ns_;
  SpecBagReport report_;
};

}  // namespace msspr::ros_bridge
