// In-memory episode collection with the data-collection experts.
#ifndef MSSPR_SIM_DATASET_GEN_H_
#define MSSPR_SIM_DATASET_GEN_H_

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "msspr_sim/expert.h"
#include "msspr_sim/point_maze.h"

namespace msspr::sim {

struct CollectOptions {
  std::string maze = "medium";
  DatasetKind kind = DatasetKind::kNavigate;
  int episode_length = 1001;
  double noise_std = 0.5;
  bool images = false;
  uint64_t seed = 0;
};

struct Episode {
  uint64_t index = 0, seed = 0;
  int length = 0;
  std::vector<float> observations;  // [length, 2] float32 row-major, metres
  // [length, 2] float32; the action at step t was taken from observation t;
  // the last action has no next state (OGBench convention).
  std::vector<float> actions;
  std::vector<uint8_t> images;                      // [length, S, S, 3] uint8 if images, else empty
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // env reset start state
  Eigen::Vector2d goal = Eigen::Vector2d::Zero();   // env goal
};

// Collects episode `index`: env.ResetRandom(EpisodeSeed(seed, index));
// expert = CollectionExpert(map, kind, noise, EpisodeSeed(seed, index));
// for t in [0, length): a = expert.Act(s); record (s, a[, image]);
// if t < length - 1: s = env.Step(a). As over ROS (float32 messages), the
// expert sees s rounded to float32 and env.Step gets a rounded to float32
// (exactly the stored value), so replaying the stored actions from `start`
// reproduces the stored observations bit for bit.
// Throws std::invalid_argument if env's maze differs from options.maze, if
// episode_length < 1, or if images are asked of a non-rendering env.
Episode CollectEpisode(PointMaze& env, const CollectOptions& options, uint64_t index);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_DATASET_GEN_H_
