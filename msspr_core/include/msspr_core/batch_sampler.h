// Goal relabelling (OGBench GCDataset), n-step returns and trajectory
// chunks, as index arrays into a Dataset. Rewards: 0 when the state equals
// the goal (exact index equality, as OGBench), else -1. This header does not
// include torch; the trainer gathers the indexed data into tensors.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "msspr_core/dataset.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

// A batch of B transitions for the critic and actor.
struct TransitionIndices {
  std::vector<int64_t> idx;  // [B] state s_t (and action a_t)
  std::vector<int64_t>
      next_idx;  // [B] bootstrap state s_{t+m}, m = min(n, steps to trajectory end)
  std::vector<int64_t> value_goal;  // [B] goal of the critic
  std::vector<int64_t> actor_goal;  // [B] goal of the actor
  std::vector<float> ret;           // [B] n-step return R^(n) to value_goal, rewards in {-1, 0}
  std::vector<float> discount;      // [B] gamma^m, or 0 when the goal is reached within the n steps
  // Sizes the per-row arrays above to `batch` (the subgoals stay as they are).
  void Resize(int batch);
  // Subgoals (HIQL's: SampleOgbenchTransitions with subgoal_steps > 0; Ms.PR's
  // subgoal policy: SampleTransitions with subgoal_steps > 0; else empty):
  std::vector<int64_t> low_goal;     // [B] s_{min(t+k, end)}, the low actor's goal
  std::vector<int64_t> high_goal;    // [B] the high actor's goal
  std::vector<int64_t> high_target;  // [B] s_{min(t+k, high_goal)} (trajectory goals) or
                                     //     s_{min(t+k, end)} (random goals): the subgoal to reach
};

// A batch of B chunks for the representation loss. The chunk starting at
// step t holds states s_t..s_{t+L-1} and actions a_t..a_{t+A-1} with
// L = max(H, H - 1 + k) + 1 and A = max(H, H - 1 + k) (k = goal horizon);
// indices past the trajectory's end are clamped to it and masked out.
struct ChunkIndices {
  int batch = 0;                   // B
  int horizon = 0;                 // H
  int num_states = 0;              // L
  int num_actions = 0;             // A
  std::vector<int64_t> states;     // [B, L]
  std::vector<float> state_mask;   // [B, L] 1 when s_{t+j} is in the trajectory
  std::vector<int64_t> actions;    // [B, A]
  std::vector<float> action_mask;  // [B, A] 1 when a_{t+j} has a next state in the trajectory
  std::vector<int64_t> goal;       // [B] value-relabelled goal of the chunk
  std::vector<float> mc_return;    // [B, H] Monte Carlo return from s_{t+h} to the goal along
                                   //        the trajectory; -1/(1-gamma) when never reached
  std::vector<float> goal_ahead;   // [B, H] 1 when the goal lies ahead of s_{t+h} in its own
                                   //        trajectory (so mc_return is its true return)
};

class BatchSampler {
 public:
  // Keeps a reference to `data`, which must outlive the sampler.
  BatchSampler(const Dataset& data, const RelabelOptions& relabel, double gamma, int n_step,
               int horizon, int goal_horizon);

  // A uniformly drawn step with a next state.
  int64_t SampleStart(std::mt19937_64& rng) const;
  // Value goal for step i: current state / future state of i's trajectory
  // (geometric offset >= 1 with p = 1 - gamma, capped at the trajectory's
  // end, or uniform in (i, end]) / random dataset state, with the
  // proportions of RelabelOptions::value_*.
  int64_t SampleValueGoal(int64_t i, std::mt19937_64& rng) const;
  // Actor goal for step i (RelabelOptions::actor_*).
  int64_t SampleActorGoal(int64_t i, std::mt19937_64& rng) const;

  // n-step return and bootstrap of the transition at i toward goal g.
  void NStep(int64_t i, int64_t g, int64_t* next_idx, float* ret, float* discount) const;
  // Monte Carlo return from step t to goal g along t's trajectory.
  float MonteCarloReturn(int64_t t, int64_t g) const;

  // Ms.PR's n-step transitions. With subgoal_steps > 0 (agent.subgoal_steps)
  // also its subgoal policy's indices (AddSubgoals).
  TransitionIndices SampleTransitions(int batch, std::mt19937_64& rng, int subgoal_steps = 0) const;
  // The subgoal policy's indices of a transition batch, from its states and
  // actor goals, without a random draw: high_goal = the actor goal drawn (the
  // subgoal actor's goal); low_goal = s_{min(t+k, end)}, which also becomes
  // the actor's goal (the actor learns to reach the subgoal); high_target =
  // s_{min(t+k, g)} for a goal g ahead in t's trajectory, else low_goal.
  void AddSubgoals(TransitionIndices* batch, int subgoal_steps) const;
  // OGBench's 1-step transitions for the baseline agents (its GCDataset):
  // next_idx = t + 1; ret = reward = 0 when the value goal is t
  // itself, else -1; discount = gamma * mask, mask = 0 when the value goal is
  // t. With subgoal_steps > 0 also HIQL's low_goal, high_goal (random with
  // probability actor_p_randomgoal, else a uniform future state) and
  // high_target.
  TransitionIndices SampleOgbenchTransitions(int batch, std::mt19937_64& rng,
                                             int subgoal_steps = 0) const;
  ChunkIndices SampleChunks(int batch, std::mt19937_64& rng) const;

 private:
  int64_t SampleGoal(int64_t i, double p_cur, double p_traj, bool geom, std::mt19937_64& rng) const;

  const Dataset& data_;
  RelabelOptions relabel_;
  double gamma_;
  int n_step_;
  int horizon_;
  int goal_horizon_;
};

}  // namespace core
}  // namespace msspr
