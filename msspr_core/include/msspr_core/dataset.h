// Trajectory store for offline goal-conditioned RL: float state vectors
// and/or uint8 images, actions, and trajectory boundaries, stored back to
// back in flat arrays (OGBench's layout). Frames are stored once; frame
// stacking happens when a batch is gathered. This header does not include
// torch.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr {
namespace core {

// Thrown on inconsistent dataset contents or arguments.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Shape of one stored image frame (uint8, HWC). All zero when none.
struct ImageShape {
  int height = 0;
  int width = 0;
  int channels = 0;
  int64_t numel() const { return int64_t{height} * width * channels; }
  bool empty() const { return numel() == 0; }
};

// Read-only dataset. Step i has a state and/or an image, and an action; the
// last step of each trajectory ("terminal") has no next state, so its action
// is never used as a transition.
class Dataset {
 public:
  Dataset() = default;

  // Takes ownership of the arrays (no copy). states: [N, obs_dim] float32
  // (empty when obs_dim == 0); images: [N, H, W, C] uint8 (empty when the
  // shape is empty); actions: [N, action_dim] float32; terminals: [N], non-zero
  // on the last step of each trajectory (the last step of the array always
  // ends a trajectory). Throws DatasetError on inconsistent sizes.
  static Dataset FromArrays(std::vector<float> states, int obs_dim, std::vector<uint8_t> images,
                            ImageShape image_shape, std::vector<float> actions, int action_dim,
                            const std::vector<uint8_t>& terminals);

  int64_t size() const { return size_; }  // N steps
  int64_t num_trajectories() const { return static_cast<int64_t>(traj_starts_.size()); }
  int obs_dim() const { return obs_dim_; }  // 0 when no states
  int action_dim() const { return action_dim_; }
  bool has_states() const { return obs_dim_ > 0; }
  bool has_images() const { return !image_shape_.empty(); }
  const ImageShape& image_shape() const { return image_shape_; }

  const float* state(int64_t i) const { return states_.data() + i * obs_dim_; }  // [obs_dim]
  const uint8_t* image(int64_t i) const {
    return images_.data() + i * image_shape_.numel();
  }  // [H, W, C]
  const float* action(int64_t i) const {
    return actions_.data() + i * action_dim_;
  }                                                               // [action_dim]
  const std::vector<float>& states() const { return states_; }    // [N, obs_dim]
  const std::vector<uint8_t>& images() const { return images_; }  // [N, H, W, C]
  const std::vector<float>& actions() const { return actions_; }  // [N, action_dim]

  int64_t trajectory_of(int64_t i) const { return traj_id_[i]; }
  int64_t trajectory_start(int64_t i) const { return traj_starts_[traj_id_[i]]; }
  int64_t trajectory_end(int64_t i) const {
    return traj_ends_[traj_id_[i]];
  }  // last step (inclusive)
  const std::vector<int64_t>& trajectory_starts() const { return traj_starts_; }
  const std::vector<int64_t>& trajectory_ends() const { return traj_ends_; }
  // Steps that have a next state (all but each trajectory's last): the
  // starts of transitions and chunks.
  const std::vector<int64_t>& valid_indices() const { return valid_; }
  // [N] 1 on each trajectory's last step.
  std::vector<uint8_t> terminals() const;

  // Copies states of `n` steps into out: [n, obs_dim] float32.
  void GatherStates(const int64_t* idx, int64_t n, float* out) const;
  // Copies images into out: [n, H, W, C * frame_stack] uint8; frame s of
  // step i is image(max(i - (frame_stack - 1 - s), trajectory_start(i)))
  // (the oldest frame first; repeated at a trajectory's start).
  void GatherImages(const int64_t* idx, int64_t n, int frame_stack, uint8_t* out) const;
  // Copies actions into out: [n, action_dim] float32.
  void GatherActions(const int64_t* idx, int64_t n, float* out) const;

 private:
  int64_t size_ = 0;
  int obs_dim_ = 0;
  int action_dim_ = 0;
  ImageShape image_shape_;
  std::vector<float> states_;         // [N, obs_dim]
  std::vector<uint8_t> images_;       // [N, H, W, C]
  std::vector<float> actions_;        // [N, action_dim]
  std::vector<int32_t> traj_id_;      // [N]
  std::vector<int64_t> traj_starts_;  // [num_trajectories]
  std::vector<int64_t> traj_ends_;    // [num_trajectories] inclusive
  std::vector<int64_t> valid_;        // non-terminal steps
};

// Fills a Dataset episode by episode (e.g. from a ROS bag); the data are
// appended to growing arrays: call Reserve with the total step count for
// large image datasets to avoid reallocation.
class DatasetBuilder {
 public:
  // obs_dim 0: no state vectors; image_shape empty: no images.
  DatasetBuilder(int obs_dim, int action_dim, ImageShape image_shape = {});

  void Reserve(int64_t total_steps);

  // Appends one trajectory of T >= 1 steps. observations: [T, obs_dim]
  // float32 (ignored when obs_dim == 0); actions: [T, action_dim] float32
  // (the last one has no next state); images: [T, H, W, C] uint8 or nullptr
  // when the builder has no image shape. Throws DatasetError on bad sizes.
  void AddEpisode(const float* observations, const float* actions, int64_t T,
                  const uint8_t* images = nullptr);
  // Same with vectors; sizes are checked against T = actions.size() / action_dim.
  void AddEpisode(const std::vector<float>& observations, const std::vector<float>& actions,
                  const std::vector<uint8_t>& images = {});

  int64_t size() const { return static_cast<int64_t>(terminals_.size()); }
  int64_t num_episodes() const { return num_episodes_; }

  // Moves the data into a Dataset; the builder is empty afterwards.
  Dataset Build();

 private:
  int obs_dim_;
  int action_dim_;
  ImageShape image_shape_;
  int64_t num_episodes_ = 0;
  std::vector<float> states_;
  std::vector<uint8_t> images_;
  std::vector<float> actions_;
  std::vector<uint8_t> terminals_;
};

}  // namespace core
}  // namespace msspr
