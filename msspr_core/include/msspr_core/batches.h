// What the agents train on and report: transition and chunk batches (built
// by the trainer's batch builder, trainer_batches.cc) and the losses of a
// step.
#pragma once

#include <torch/torch.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace msspr {
namespace core {

// Observations below ("obs"): [B, obs_dim] float32 (state mode) or
// [B, H, W, C * frame_stack] uint8 (pixels mode); goals likewise.
struct TransitionBatch {
  torch::Tensor obs;         // [B, ...] s_t
  torch::Tensor action;      // [B, action_dim] float32 a_t
  torch::Tensor next_obs;    // [B, ...] bootstrap state s_{t+m}
  torch::Tensor value_goal;  // [B, ...] goal of the critic
  torch::Tensor actor_goal;  // [B, ...] goal of the actor
  torch::Tensor ret;         // [B] float32 n-step return (rewards -1 / 0)
  torch::Tensor discount;    // [B] float32 gamma^m, 0 after success
  // Subgoals, HIQL's or Ms.PR's subgoal policy's (undefined unless sampled):
  // low-level goal, high-level goal and the subgoal target (see
  // TransitionIndices).
  torch::Tensor low_goal, high_goal, high_target;
};

struct ChunkBatch {
  torch::Tensor states;       // [B, L, ...] s_t..s_{t+L-1}
  torch::Tensor state_mask;   // [B, L] float32
  torch::Tensor actions;      // [B, A, action_dim] float32
  torch::Tensor action_mask;  // [B, A] float32
  torch::Tensor goal;         // [B, ...]
  torch::Tensor mc_return;    // [B, H] float32 Monte Carlo return to the goal
  torch::Tensor goal_ahead;   // [B, H] float32 1 when the goal is ahead in the same trajectory
                              // (only with representation.reward_goals "trajectory")
};

using NamedValues = std::vector<std::pair<std::string, double>>;

// Latest losses (NaN when not computed in that step).
struct LossInfo {
  double repr = NAN, dyn = NAN, rew = NAN, inv = NAN, goal_dyn = NAN, goal_act = NAN;
  double critic = NAN, q_mean = NAN, actor = NAN, bc = NAN;
  // A baseline agent's values (GcAgent::LossNames order); when not empty,
  // Named() returns these instead of Ms.PR's.
  NamedValues agent;
  // Ms.PR's losses of optional parts (the subgoal actor's "subgoal"), after
  // the others in Named().
  NamedValues extra;
  NamedValues Named() const;
};

}  // namespace core
}  // namespace msspr
