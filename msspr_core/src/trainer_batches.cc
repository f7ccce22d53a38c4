// The trainer's batch builder: sampled indices to device tensors (gathered
// observations and actions, masks, returns) with DrQ random shifts for pixels.
#include <algorithm>
#include <cstring>
#include <vector>

#include "msspr_core/trainer.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

namespace {

// Random shift (DrQ): replicate-pad by `pad` and crop back, in place on
// one uint8 HWC image.
void ShiftImage(uint8_t* img, int h, int w, int c, int dy, int dx, std::vector<uint8_t>* scratch) {
  scratch->assign(img, img + int64_t{h} * w * c);
  const uint8_t* src = scratch->data();
  for (int y = 0; y < h; ++y) {
    const int sy = std::clamp(y + dy, 0, h - 1);
    for (int x = 0; x < w; ++x) {
      const int sx = std::clamp(x + dx, 0, w - 1);
      std::memcpy(img + (int64_t{y} * w + x) * c, src + (int64_t{sy} * w + sx) * c, c);
    }
  }
}

void ShiftSampleImages(const std::vector<std::pair<int, int>>& shifts,
                       const std::vector<torch::Tensor*>& images) {
  // images: tensors of [B * n, H, W, C] uint8, the n images of sample k in
  // rows k * n .. k * n + n - 1; each gets sample k's shift.
  if (shifts.empty()) return;
  const int64_t b = static_cast<int64_t>(shifts.size());
  std::vector<uint8_t> scratch;
  for (torch::Tensor* t : images) {
    TORCH_CHECK(t->dim() == 4 && t->scalar_type() == torch::kUInt8 && t->is_contiguous() &&
                    t->size(0) % b == 0,
                "ShiftSampleImages: expects contiguous uint8 [B * n, H, W, C] images");
    const int64_t per_sample = t->size(0) / b;  // the sample's images are consecutive rows
    const int h = t->size(1), w = t->size(2), c = t->size(3);
    const int64_t stride = int64_t{h} * w * c;
    uint8_t* data = t->data_ptr<uint8_t>();
    for (int64_t k = 0; k < b; ++k) {
      const auto [dy, dx] = shifts[k];
      if (dy == 0 && dx == 0) continue;
      for (int64_t j = 0; j < per_sample; ++j) {
        ShiftImage(data + (k * per_sample + j) * stride, h, w, c, dy, dx, &scratch);
      }
    }
  }
}

}  // namespace

torch::Tensor Trainer::ToDevice(const torch::Tensor& cpu) const {
  return device_.is_cpu() ? cpu : cpu.to(device_, /*non_blocking=*/false);
}

torch::Tensor Trainer::GatherObs(const Dataset& data, const std::vector<int64_t>& idx) const {
  const int64_t n = static_cast<int64_t>(idx.size());
  const NetworkOptions& o = options_.network;
  if (o.obs_mode == "state") {
    torch::Tensor t = torch::empty({n, o.obs_dim}, torch::kFloat32);
    data.GatherStates(idx.data(), n, t.data_ptr<float>());
    return t;
  }
  const int c = o.image_channels * o.frame_stack;
  torch::Tensor t = torch::empty({n, o.image_height, o.image_width, c}, torch::kUInt8);
  data.GatherImages(idx.data(), n, o.frame_stack, t.data_ptr<uint8_t>());
  return t;
}

std::vector<std::pair<int, int>> Trainer::DrawShifts(int64_t batch) {
  // As OGBench: one Bernoulli draw decides for the whole batch, then one
  // random shift per sample.
  const RepresentationOptions& r = options_.representation;
  std::vector<std::pair<int, int>> shifts;
  if (options_.network.obs_mode != "pixels" || r.augment_prob <= 0) return shifts;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng_) >= r.augment_prob) return shifts;
  std::uniform_int_distribution<int> shift(-r.augment_pad, r.augment_pad);
  shifts.resize(batch);
  for (auto& s : shifts) {
    s.first = shift(rng_);
    s.second = shift(rng_);
  }
  return shifts;
}

TransitionBatch Trainer::MakeTransitionBatch(const TransitionIndices& idx, bool augment,
                                             const Dataset* data) {
  const Dataset& d = data ? *data : *data_;
  const int64_t b = static_cast<int64_t>(idx.idx.size());
  torch::Tensor obs = GatherObs(d, idx.idx), next_obs = GatherObs(d, idx.next_idx);
  torch::Tensor value_goal = GatherObs(d, idx.value_goal),
                actor_goal = GatherObs(d, idx.actor_goal);
  torch::Tensor low_goal, high_goal, high_target;  // subgoals
  std::vector<torch::Tensor*> images{&obs, &next_obs, &value_goal, &actor_goal};
  if (!idx.low_goal.empty()) {
    low_goal = GatherObs(d, idx.low_goal);
    high_goal = GatherObs(d, idx.high_goal);
    high_target = GatherObs(d, idx.high_target);
    images.insert(images.end(), {&low_goal, &high_goal, &high_target});
  }
  // One shift per sample, shared by its observation, next observation and goals.
  if (augment) ShiftSampleImages(DrawShifts(b), images);
  TransitionBatch batch;
  batch.obs = ToDevice(obs);
  batch.next_obs = ToDevice(next_obs);
  batch.value_goal = ToDevice(value_goal);
  batch.actor_goal = ToDevice(actor_goal);
  torch::Tensor act = torch::empty({b, d.action_dim()}, torch::kFloat32);
  d.GatherActions(idx.idx.data(), b, act.data_ptr<float>());
  batch.action = ToDevice(act);
  batch.ret =
      ToDevice(torch::from_blob(const_cast<float*>(idx.ret.data()), {b}, torch::kFloat32).clone());
  batch.discount = ToDevice(
      torch::from_blob(const_cast<float*>(idx.discount.data()), {b}, torch::kFloat32).clone());
  if (low_goal.defined()) {
    batch.low_goal = ToDevice(low_goal);
    batch.high_goal = ToDevice(high_goal);
    batch.high_target = ToDevice(high_target);
  }
  return batch;
}

ChunkBatch Trainer::MakeChunkBatch(const ChunkIndices& idx, bool augment, const Dataset* data) {
  const Dataset& d = data ? *data : *data_;
  const int64_t b = idx.batch, l = idx.num_states, a = idx.num_actions;
  ChunkBatch batch;
  torch::Tensor states = GatherObs(d, idx.states);  // [B * L, ...], sample-major
  torch::Tensor goal = GatherObs(d, idx.goal);      // [B, ...]
  if (augment) ShiftSampleImages(DrawShifts(b), {&states, &goal});
  std::vector<int64_t> shape{b, l};
  for (int64_t j = 1; j < states.dim(); ++j) shape.push_back(states.size(j));
  batch.states = ToDevice(states.view(shape));
  batch.state_mask = ToDevice(
      torch::from_blob(const_cast<float*>(idx.state_mask.data()), {b, l}, torch::kFloat32).clone());
  torch::Tensor act = torch::empty({b * a, d.action_dim()}, torch::kFloat32);
  d.GatherActions(idx.actions.data(), b * a, act.data_ptr<float>());
  batch.actions = ToDevice(act.view({b, a, d.action_dim()}));
  batch.action_mask =
      ToDevice(torch::from_blob(const_cast<float*>(idx.action_mask.data()), {b, a}, torch::kFloat32)
                   .clone());
  batch.goal = ToDevice(goal);
  batch.mc_return = ToDevice(
      torch::from_blob(const_cast<float*>(idx.mc_return.data()), {b, idx.horizon}, torch::kFloat32)
          .clone());
  // Read only by the reward term with representation.reward_goals "trajectory".
  if (options_.representation.reward_goals == "trajectory") {
    batch.goal_ahead = ToDevice(torch::from_blob(const_cast<float*>(idx.goal_ahead.data()),
                                                 {b, idx.horizon}, torch::kFloat32)
                                    .clone());
  }
  return batch;
}

TransitionBatch Trainer::SampleTransitions() {
  const bool augment = options_.network.obs_mode == "pixels";
  return MakeTransitionBatch(
      sampler_->SampleTransitions(local_batch(), rng_, options_.agent.subgoal_steps), augment);
}

ChunkBatch Trainer::SampleChunks() {
  const bool augment = options_.network.obs_mode == "pixels";
  return MakeChunkBatch(sampler_->SampleChunks(local_batch(), rng_), augment);
}

}  // namespace core
}  // namespace msspr
