#include "msspr_core/batch_sampler.h"

#include <algorithm>
#include <cmath>

namespace msspr {
namespace core {

BatchSampler::BatchSampler(const Dataset& data, const RelabelOptions& relabel, double gamma,
                           int n_step, int horizon, int goal_horizon)
    : data_(data),
      relabel_(relabel),
      gamma_(gamma),
      n_step_(n_step),
      horizon_(horizon),
      goal_horizon_(goal_horizon) {
  if (data.valid_indices().empty()) throw DatasetError("BatchSampler: dataset has no transition");
}

int64_t BatchSampler::SampleStart(std::mt19937_64& rng) const {
  const auto& valid = data_.valid_indices();
  std::uniform_int_distribution<int64_t> pick(0, static_cast<int64_t>(valid.size()) - 1);
  return valid[pick(rng)];
}

int64_t BatchSampler::SampleGoal(int64_t i, double p_cur, double p_traj, bool geom,
                                 std::mt19937_64& rng) const {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double u = unit(rng);
  if (u < p_cur) return i;
  const int64_t end = data_.trajectory_end(i);
  if (u < p_cur + p_traj) {
    if (i >= end) return end;
    if (geom) {
      // numpy's geometric counts trials (>= 1); std's counts failures (>= 0).
      std::geometric_distribution<int64_t> offset(1.0 - gamma_);
      return std::min(i + 1 + offset(rng), end);
    }
    std::uniform_int_distribution<int64_t> future(i + 1, end);
    return future(rng);
  }
  std::uniform_int_distribution<int64_t> any(0, data_.size() - 1);
  return any(rng);
}

int64_t BatchSampler::SampleValueGoal(int64_t i, std::mt19937_64& rng) const {
  return SampleGoal(i, relabel_.value_p_curgoal, relabel_.value_p_trajgoal,
                    relabel_.value_geom_sample, rng);
}

int64_t BatchSampler::SampleActorGoal(int64_t i, std::mt19937_64& rng) const {
  return SampleGoal(i, relabel_.actor_p_curgoal, relabel_.actor_p_trajgoal,
                    relabel_.actor_geom_sample, rng);
}

void BatchSampler::NStep(int64_t i, int64_t g, int64_t* next_idx, float* ret,
                         float* discount) const {
  const int64_t end = data_.trajectory_end(i);
  const int64_t m = std::max<int64_t>(1, std::min<int64_t>(n_step_, end - i));
  double r = 0.0, scale = 1.0;
  for (int64_t k = 0; k < m; ++k) {
    if (i + k == g) {  // reward 0 and no bootstrap from the first success on
      *next_idx = i + k;
      *ret = static_cast<float>(r);
      *discount = 0.0f;
      return;
    }
    r -= scale;
    scale *= gamma_;
  }
  *next_idx = std::min(i + m, end);
  *ret = static_cast<float>(r);
  // Reaching the goal exactly at the bootstrap state ends the return too.
  *discount = (*next_idx == g) ? 0.0f : static_cast<float>(scale);
}

float BatchSampler::MonteCarloReturn(int64_t t, int64_t g) const {
  const int64_t end = data_.trajectory_end(t);
  if (g >= t && g <= end) {
    const double d = static_cast<double>(g - t);
    return static_cast<float>(-(1.0 - std::pow(gamma_, d)) / (1.0 - gamma_));
  }
  return static_cast<float>(-1.0 / (1.0 - gamma_));
}

void TransitionIndices::Resize(int batch) {
  for (auto* v : {&idx, &next_idx, &value_goal, &actor_goal}) v->resize(batch);
  ret.resize(batch);
  discount.resize(batch);
}

TransitionIndices BatchSampler::SampleTransitions(int batch, std::mt19937_64& rng,
                                                  int subgoal_steps) const {
  TransitionIndices b;
  b.Resize(batch);
  for (int k = 0; k < batch; ++k) {
    const int64_t i = SampleStart(rng);
    b.idx[k] = i;
    b.value_goal[k] = SampleValueGoal(i, rng);
    b.actor_goal[k] = SampleActorGoal(i, rng);
    NStep(i, b.value_goal[k], &b.next_idx[k], &b.ret[k], &b.discount[k]);
  }
  if (subgoal_steps > 0) AddSubgoals(&b, subgoal_steps);
  return b;
}

void BatchSampler::AddSubgoals(TransitionIndices* b, int subgoal_steps) const {
  // No random draw: the subgoals follow from the states and the actor goals
  // drawn, so the stream (and every other index) is the one without them.
  const size_t n = b->idx.size();
  b->low_goal.resize(n);
  b->high_goal.resize(n);
  b->high_target.resize(n);
  for (size_t k = 0; k < n; ++k) {
    const int64_t i = b->idx[k], g = b->actor_goal[k];
    const int64_t end = data_.trajectory_end(i);
    const int64_t low = std::min<int64_t>(i + subgoal_steps, end);
    b->high_goal[k] = g;
    // A goal ahead in the same trajectory: the subgoal on the way to it, or
    // the goal itself when it is nearer than k steps.
    b->high_target[k] = (g >= i && g <= end) ? std::min<int64_t>(low, g) : low;
    b->low_goal[k] = low;
    b->actor_goal[k] = low;
  }
}

TransitionIndices BatchSampler::SampleOgbenchTransitions(int batch, std::mt19937_64& rng,
                                                         int subgoal_steps) const {
  TransitionIndices b;
  b.Resize(batch);
  if (subgoal_steps > 0) {
    b.low_goal.resize(batch);
    b.high_goal.resize(batch);
    b.high_target.resize(batch);
  }
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < batch; ++k) {
    const int64_t i = SampleStart(rng);
    b.idx[k] = i;
    b.next_idx[k] = i + 1;  // a valid index always has a next state
    b.value_goal[k] = SampleValueGoal(i, rng);
    b.actor_goal[k] = SampleActorGoal(i, rng);
    const bool success = b.value_goal[k] == i;
    b.ret[k] = success ? 0.0f : -1.0f;
    b.discount[k] = success ? 0.0f : static_cast<float>(gamma_);
    if (subgoal_steps > 0) {
      const int64_t end = data_.trajectory_end(i);
      b.low_goal[k] = std::min<int64_t>(i + subgoal_steps, end);
      if (unit(rng) < relabel_.actor_p_randomgoal) {
        std::uniform_int_distribution<int64_t> any(0, data_.size() - 1);
        b.high_goal[k] = any(rng);
        b.high_target[k] = b.low_goal[k];
      } else {
        std::uniform_int_distribution<int64_t> future(i + 1, end);
        b.high_goal[k] = future(rng);
        b.high_target[k] = std::min<int64_t>(i + subgoal_steps, b.high_goal[k]);
      }
    }
  }
  return b;
}

ChunkIndices BatchSampler::SampleChunks(int batch, std::mt19937_64& rng) const {
  ChunkIndices c;
  const int H = horizon_;
  const int span = std::max(H, H - 1 + goal_horizon_);
  c.batch = batch;
  c.horizon = H;
  c.num_states = span + 1;
  c.num_actions = span;
  c.states.resize(int64_t{batch} * c.num_states);
  c.state_mask.resize(c.states.size());
  c.actions.resize(int64_t{batch} * c.num_actions);
  c.action_mask.resize(c.actions.size());
  c.goal.resize(batch);
  c.mc_return.resize(int64_t{batch} * H);
  c.goal_ahead.resize(c.mc_return.size());
  for (int b = 0; b < batch; ++b) {
    const int64_t t = SampleStart(rng);
    const int64_t end = data_.trajectory_end(t);
    for (int j = 0; j < c.num_states; ++j) {
      c.states[b * c.num_states + j] = std::min<int64_t>(t + j, end);
      c.state_mask[b * c.num_states + j] = (t + j <= end) ? 1.0f : 0.0f;
    }
    for (int j = 0; j < c.num_actions; ++j) {
      c.actions[b * c.num_actions + j] = std::min<int64_t>(t + j, end);
      c.action_mask[b * c.num_actions + j] = (t + j < end) ? 1.0f : 0.0f;
    }
    const int64_t g = SampleValueGoal(t, rng);
    c.goal[b] = g;
    for (int h = 0; h < H; ++h) {
      const int64_t s = std::min<int64_t>(t + h, end);
      c.mc_return[b * H + h] = MonteCarloReturn(s, g);
      c.goal_ahead[b * H + h] = (g >= s && g <= end) ? 1.0f : 0.0f;
    }
  }
  return c;
}

}  // namespace core
}  // namespace msspr
