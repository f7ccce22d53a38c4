// The dataset bag format of msspr, shared by the direct writer (msspr_collect),
// `rosbag record` of the live sim node, msspr_bag_info and the training adapter.
//
// Layout (docs/datasets.md): per episode one msspr/EpisodeInfo on
// /msspr/episode, then for every step t one msspr/Observation (episode_id, step=t)
// on /msspr/observation, optionally one sensor_msgs/Image (rgb8, stamp equal to the
// observation's) on /msspr/camera/image, and one msspr/Action (same episode_id and
// step) on /msspr/action. Transition t is (observation t, action t, observation t+1);
// the last action of an episode has no next state (OGBench's convention).
//
// dataset_bag_writer.cc writes bags; dataset_bag_reader.cc reads them after the
// checks of dataset_bag_validator.h (the file's structure, and each message's
// bytes against the layout derived from its generated type).
#pragma once

#include <ros/time.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace rosbag {
class Bag;
}

namespace msspr::ros_bridge {

inline constexpr char kEpisodeTopic[] = "/msspr/episode";
inline constexpr char kObservationTopic[] = "/msspr/observation";
inline constexpr char kActionTopic[] = "/msspr/action";
inline constexpr char kImageTopic[] = "/msspr/camera/image";
inline constexpr char kCameraFrame[] = "msspr_camera";

// Sanity limits of the reader: a message whose `step` is at or beyond
// kMaxEpisodeSteps, or beyond twice the number of distinct steps its episode
// carries, is rejected and counted (out_of_range_steps); images wider than
// kMaxImageSide are inconsistent; an episode's images may take at most
// kMaxEpisodeImageBytes.
inline constexpr uint32_t kMaxEpisodeSteps = 1000000;
inline constexpr uint32_t kMaxImageSide = 4096;
inline constexpr uint64_t kMaxEpisodeImageBytes = uint64_t{4} << 30;

// A bag that cannot be read, or whose content breaks the layout; what() names the file.
class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct EpisodeMeta {
  uint64_t episode_id = 0;
  std::string env;  // e.g. "pointmaze-medium"
  std::string split = "train";
  int task_id = 0;
  uint64_t seed = 0;
  std::vector<float> start;  // [obs_dim]
  std::vector<float> goal;   // [obs_dim]
};

// Writes dataset bags through the rosbag C++ API (no master needed). It writes
// to `path`.tmp.<pid> and renames it to `path` in Close(): an existing bag at
// `path` stays untouched until the new one is complete, and a writer destroyed
// without Close() (an error, an abandoned collection) removes its temporary
// file and leaves `path` as it was.
class DatasetBagWriter {
 public:
  // Opens the temporary file, LZ4-compressed unless lz4 is false; throws BagError.
  DatasetBagWriter(const std::string& path, double control_dt, bool lz4 = true);
  ~DatasetBagWriter();

  // Writes one episode of `length` steps. observations/actions: [length, obs_dim] /
  // [length, act_dim] float32 row-major; images: [length, image_size, image_size, 3]
  // uint8 or nullptr. Stamps follow TickToTime: one tick for the reset, one per step.
  // A step's `success` flag: the distance between the first `success_dims` values of
  // the state and of the goal (all of them when < 1) is within success_radius (the
  // ant mazes: 2, the torso's xy; the goal is a full state).
  void WriteEpisode(const EpisodeMeta& meta, int length, int obs_dim, int act_dim,
                    const float* observations, const float* actions, const uint8_t* images,
                    int image_size, double success_radius, int success_dims = 0);

  uint64_t messages() const { return messages_; }
  // Finishes the bag and renames it to `path`; throws BagError.
  void Close();

 private:
  std::string path_, tmp_path_;
  bool closed_ = false;
  double control_dt_;
  uint64_t tick_ = 0;
  uint64_t messages_ = 0;
  std::unique_ptr<rosbag::Bag> bag_;
};

// One episode read back from a bag. Arrays cover steps [0, num_steps); a step
// whose observation or action (or image, when the episode has images) is missing
// is marked absent and never bridged: Segments() gives the complete runs.
struct BagEpisode {
  EpisodeMeta meta;
  bool has_meta = false;
  int num_steps = 0;  // 1 + the highest step seen
  int obs_dim = 0, act_dim = 0;
  int image_size = 0;               // 0 when the episode has no images
  std::vector<float> observations;  // [num_steps, obs_dim]
  std::vector<float> actions;       // [num_steps, act_dim]
  std::vector<uint8_t> images;      // [num_steps, image_size, image_size, 3] or empty
  std::vector<uint8_t> has_obs, has_action, has_image;  // [num_steps] 0/1
  // Robot bags through a spec with a pose or observation goal on a recorded topic:
  // the goal in effect at each step [num_steps, obs_dim], NaN before the first;
  // empty otherwise.
  std::vector<float> goals;
  std::vector<std::string> problems;  // human-readable, empty when the episode is whole
  // Step t's time is t0 + t * step_period (s; a robot's bags through a spec: its ticks).
  // 0 / 0 when unknown (msspr dataset bags number their steps).
  double t0 = 0, step_period = 0;

  // Runs [begin, end) of consecutive steps with all their data, in order.
  std::vector<std::pair<int, int>> Segments() const;
  bool complete() const { return problems.empty(); }
};

struct BagReadReport {
  uint64_t messages = 0, episodes = 0, complete_episodes = 0, steps = 0;
  uint64_t missing_observations = 0, missing_actions = 0, missing_images = 0;
  uint64_t duplicates = 0, foreign_messages = 0;
  uint64_t out_of_range_steps = 0, nonfinite_observations = 0, nonfinite_actions = 0,
           bad_images = 0;
  std::vector<std::string> problems;  // episode-level and bag-level, "episode 3: ..."
};

// Streams a dataset bag episode by episode in one pass (memory for ~2 episodes).
class DatasetBagReader {
 public:
  explicit DatasetBagReader(std::string path);  // throws BagError naming the path
  ~DatasetBagReader();

  // Calls fn for each episode in increasing episode_id. Throws BagError naming the
  // file when the bag is truncated or corrupt (after the episodes read so far),
  // also for a message that cannot be deserialized. Exceptions of fn pass through.
  // Steps out of range, observations/actions with NaN or Inf and inconsistent
  // images are rejected, counted in report() and listed in the episode's problems.
  void ForEachEpisode(const std::function<void(BagEpisode&&)>& fn);
  const BagReadReport& report() const { return report_; }
  const std::string& path() const { return path_; }
  // Observation messages in the bag (all splits), from its index: an upper
  // bound on the steps ForEachEpisode yields, to reserve memory up front.
  uint64_t CountObservations() const;

 private:
  std::string path_;
  std::unique_ptr<rosbag::Bag> bag_;
  BagReadReport report_;
};

}  // namespace msspr::ros_bridge
