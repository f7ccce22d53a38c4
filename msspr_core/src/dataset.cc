#include "msspr_core/dataset.h"

#include <algorithm>
#include <cstring>
#include <limits>

#include "msspr_core/frame_stack.h"

namespace msspr {
namespace core {

Dataset Dataset::FromArrays(std::vector<float> states, int obs_dim, std::vector<uint8_t> images,
                            ImageShape image_shape, std::vector<float> actions, int action_dim,
                            const std::vector<uint8_t>& terminals) {
  const int64_t n = static_cast<int64_t>(terminals.size());
  if (n == 0) throw DatasetError("dataset is empty");
  if (action_dim <= 0) throw DatasetError("action_dim must be > 0");
  if (obs_dim < 0) throw DatasetError("obs_dim must be >= 0");
  if (obs_dim == 0 && image_shape.empty())
    throw DatasetError("dataset has neither states nor images");
  if (static_cast<int64_t>(states.size()) != n * obs_dim) {
    throw DatasetError("states have " + std::to_string(states.size()) + " values, expected " +
                       std::to_string(n * obs_dim));
  }
  if (static_cast<int64_t>(images.size()) != n * image_shape.numel()) {
    throw DatasetError("images have " + std::to_string(images.size()) + " values, expected " +
                       std::to_string(n * image_shape.numel()));
  }
  if (static_cast<int64_t>(actions.size()) != n * action_dim) {
    throw DatasetError("actions have " + std::to_string(actions.size()) + " values, expected " +
                       std::to_string(n * action_dim));
  }
  if (n > std::numeric_limits<int32_t>::max()) throw DatasetError("dataset too large");
  Dataset d;
  d.size_ = n;
  d.obs_dim_ = obs_dim;
  d.action_dim_ = action_dim;
  d.image_shape_ = image_shape;
  d.states_ = std::move(states);
  d.images_ = std::move(images);
  d.actions_ = std::move(actions);
  d.traj_id_.resize(n);
  int64_t start = 0;
  for (int64_t i = 0; i < n; ++i) {
    d.traj_id_[i] = static_cast<int32_t>(d.traj_starts_.size());
    if (terminals[i] || i == n - 1) {
      d.traj_starts_.push_back(start);
      d.traj_ends_.push_back(i);
      start = i + 1;
    } else {
      d.valid_.push_back(i);
    }
  }
  if (d.valid_.empty())
    throw DatasetError("dataset has no transition (all trajectories have 1 step)");
  return d;
}

std::vector<uint8_t> Dataset::terminals() const {
  std::vector<uint8_t> t(size_, 0);
  for (int64_t e : traj_ends_) t[e] = 1;
  return t;
}

void Dataset::GatherStates(const int64_t* idx, int64_t n, float* out) const {
  for (int64_t k = 0; k < n; ++k) {
    std::memcpy(out + k * obs_dim_, state(idx[k]), sizeof(float) * obs_dim_);
  }
}

void Dataset::GatherActions(const int64_t* idx, int64_t n, float* out) const {
  for (int64_t k = 0; k < n; ++k) {
    std::memcpy(out + k * action_dim_, action(idx[k]), sizeof(float) * action_dim_);
  }
}

void Dataset::GatherImages(const int64_t* idx, int64_t n, int frame_stack, uint8_t* out) const {
  const int64_t pixels = int64_t{image_shape_.height} * image_shape_.width;
  const int c = image_shape_.channels;
  if (frame_stack == 1) {
    for (int64_t k = 0; k < n; ++k) std::memcpy(out + k * pixels * c, image(idx[k]), pixels * c);
    return;
  }
  const FrameStacker stacker(image_shape_.height, image_shape_.width, c, frame_stack);
  std::vector<const uint8_t*> frames(static_cast<size_t>(frame_stack));
  for (int64_t k = 0; k < n; ++k) {
    const int64_t i = idx[k];
    const int64_t start = trajectory_start(i);
    for (int s = 0; s < frame_stack; ++s)
      frames[s] = image(std::max(i - (frame_stack - 1 - s), start));
    stacker.Interleave(frames.data(), out + k * static_cast<int64_t>(stacker.stacked_bytes()));
  }
}

DatasetBuilder::DatasetBuilder(int obs_dim, int action_dim, ImageShape image_shape)
    : obs_dim_(obs_dim), action_dim_(action_dim), image_shape_(image_shape) {
  if (action_dim <= 0) throw DatasetError("DatasetBuilder: action_dim must be > 0");
  if (obs_dim < 0) throw DatasetError("DatasetBuilder: obs_dim must be >= 0");
  if (obs_dim == 0 && image_shape.empty()) {
    throw DatasetError("DatasetBuilder: needs states (obs_dim > 0) or images");
  }
}

void DatasetBuilder::Reserve(int64_t total_steps) {
  states_.reserve(total_steps * obs_dim_);
  images_.reserve(total_steps * image_shape_.numel());
  actions_.reserve(total_steps * action_dim_);
  terminals_.reserve(total_steps);
}

void DatasetBuilder::AddEpisode(const float* observations, const float* actions, int64_t T,
                                const uint8_t* images) {
  if (T < 1) throw DatasetError("AddEpisode: episode needs at least 1 step");
  if (obs_dim_ > 0 && observations == nullptr)
    throw DatasetError("AddEpisode: observations missing");
  if (actions == nullptr) throw DatasetError("AddEpisode: actions missing");
  if (!image_shape_.empty() && images == nullptr) throw DatasetError("AddEpisode: images missing");
  if (image_shape_.empty() && images != nullptr) {
    throw DatasetError("AddEpisode: images given but the builder has no image shape");
  }
  if (obs_dim_ > 0) states_.insert(states_.end(), observations, observations + T * obs_dim_);
  actions_.insert(actions_.end(), actions, actions + T * action_dim_);
  if (!image_shape_.empty())
    images_.insert(images_.end(), images, images + T * image_shape_.numel());
  terminals_.insert(terminals_.end(), T - 1, 0);
  terminals_.push_back(1);
  ++num_episodes_;
}

void DatasetBuilder::AddEpisode(const std::vector<float>& observations,
                                const std::vector<float>& actions,
                                const std::vector<uint8_t>& images) {
  if (actions.size() % action_dim_ != 0) {
    throw DatasetError("AddEpisode: actions size " + std::to_string(actions.size()) +
                       " is not a multiple of action_dim " + std::to_string(action_dim_));
  }
  const int64_t T = static_cast<int64_t>(actions.size()) / action_dim_;
  if (static_cast<int64_t>(observations.size()) != T * obs_dim_) {
    throw DatasetError("AddEpisode: observations size " + std::to_string(observations.size()) +
                       " != T * obs_dim = " + std::to_string(T * obs_dim_));
  }
  if (static_cast<int64_t>(images.size()) != T * image_shape_.numel()) {
    throw DatasetError("AddEpisode: images size " + std::to_string(images.size()) +
                       " != T * H * W * C = " + std::to_string(T * image_shape_.numel()));
  }
  AddEpisode(observations.data(), actions.data(), T, images.empty() ? nullptr : images.data());
}

Dataset DatasetBuilder::Build() {
  Dataset d = Dataset::FromArrays(std::move(states_), obs_dim_, std::move(images_), image_shape_,
                                  std::move(actions_), action_dim_, terminals_);
  states_.clear();
  images_.clear();
  actions_.clear();
  terminals_.clear();
  num_episodes_ = 0;
  return d;
}

}  // namespace core
}  // namespace msspr
