#include "msspr_core/batch_sampler.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace msspr {
namespace core {
namespace {

Dataset MakeDataset(const std::vector<int>& lengths) {
  DatasetBuilder b(1, 1);
  for (int T : lengths) {
    std::vector<float> obs(T), act(T);
    for (int t = 0; t < T; ++t) obs[t] = static_cast<float>(t);
    b.AddEpisode(obs, act);
  }
  return b.Build();
}

TEST(BatchSamplerTest, ValueGoalProportions) {
  const Dataset d = MakeDataset(std::vector<int>(100, 100));
  RelabelOptions r;  // 0.2 / 0.5 / 0.3
  BatchSampler s(d, r, 0.99, 3, 5, 5);
  std::mt19937_64 rng(1);
  int cur = 0, traj = 0, other = 0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const int64_t i = s.SampleStart(rng);
    const int64_t g = s.SampleValueGoal(i, rng);
    if (g == i)
      ++cur;
    else if (d.trajectory_of(g) == d.trajectory_of(i) && g > i)
      ++traj;
    else
      ++other;
  }
  // Random goals land in the same trajectory's future ~0.5% of the time.
  EXPECT_NEAR(cur / double(n), 0.2, 0.01);
  EXPECT_NEAR(traj / double(n), 0.5, 0.01);
  EXPECT_NEAR(other / double(n), 0.3, 0.01);
}

TEST(BatchSamplerTest, ActorGoalsAndStitchProportions) {
  const Dataset d = MakeDataset(std::vector<int>(100, 100));
  RelabelOptions r;
  r.actor_p_trajgoal = 0.5;
  r.actor_p_randomgoal = 0.5;
  BatchSampler s(d, r, 0.99, 3, 5, 5);
  std::mt19937_64 rng(2);
  int traj = 0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const int64_t i = s.SampleStart(rng);
    const int64_t g = s.SampleActorGoal(i, rng);
    if (d.trajectory_of(g) == d.trajectory_of(i) && g > i) ++traj;
  }
  EXPECT_NEAR(traj / double(n), 0.5, 0.01);
}

TEST(BatchSamplerTest, GeometricOffsets) {
  const Dataset d = MakeDataset({20000});
  RelabelOptions r;
  r.value_p_curgoal = 0.0;
  r.value_p_trajgoal = 1.0;
  r.value_p_randomgoal = 0.0;
  const double gamma = 0.99;
  BatchSampler s(d, r, gamma, 3, 5, 5);
  std::mt19937_64 rng(3);
  const int n = 100000;
  double sum = 0;
  int ones = 0;
  for (int k = 0; k < n; ++k) {
    const int64_t off = s.SampleValueGoal(0, rng);
    ASSERT_GE(off, 1);
    sum += off;
    ones += off == 1;
  }
  // numpy's geometric(p): mean 1/p, P(1) = p, p = 1 - gamma.
  EXPECT_NEAR(sum / n, 1.0 / (1.0 - gamma), 1.5);
  EXPECT_NEAR(ones / double(n), 1.0 - gamma, 0.002);
  // Capped at the trajectory's last step.
  for (int k = 0; k < 1000; ++k) EXPECT_LE(s.SampleValueGoal(19990, rng), 19999);
  EXPECT_EQ(s.SampleValueGoal(19998, rng), 19999);
}

TEST(BatchSamplerTest, UniformFutureActorGoals) {
  const Dataset d = MakeDataset({101});
  RelabelOptions r;  // actor: uniform future
  BatchSampler s(d, r, 0.99, 3, 5, 5);
  std::mt19937_64 rng(4);
  double sum = 0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const int64_t g = s.SampleActorGoal(0, rng);
    ASSERT_GE(g, 1);
    ASSERT_LE(g, 100);
    sum += g;
  }
  EXPECT_NEAR(sum / n, 50.5, 0.5);
}

TEST(BatchSamplerTest, NStepReturnsStopAtSuccess) {
  const Dataset d = MakeDataset({50, 50});
  const double g = 0.9;
  BatchSampler s(d, RelabelOptions(), g, 3, 5, 5);
  int64_t next;
  float ret, disc;
  s.NStep(10, 10, &next, &ret, &disc);  // goal = current state
  EXPECT_FLOAT_EQ(ret, 0.0f);
  EXPECT_FLOAT_EQ(disc, 0.0f);
  s.NStep(10, 11, &next, &ret, &disc);  // reached after one step
  EXPECT_FLOAT_EQ(ret, -1.0f);
  EXPECT_FLOAT_EQ(disc, 0.0f);
  s.NStep(10, 13, &next, &ret, &disc);  // reached at the bootstrap state
  EXPECT_FLOAT_EQ(ret, static_cast<float>(-1 - g - g * g));
  EXPECT_FLOAT_EQ(disc, 0.0f);
  s.NStep(10, 30, &next, &ret, &disc);  // not reached: bootstrap from s_{t+3}
  EXPECT_EQ(next, 13);
  EXPECT_FLOAT_EQ(ret, static_cast<float>(-1 - g - g * g));
  EXPECT_FLOAT_EQ(disc, static_cast<float>(g * g * g));
  s.NStep(48, 70, &next, &ret, &disc);  // one step before the trajectory's end
  EXPECT_EQ(next, 49);
  EXPECT_FLOAT_EQ(ret, -1.0f);
  EXPECT_FLOAT_EQ(disc, static_cast<float>(g));
  s.NStep(47, 70, &next, &ret, &disc);
  EXPECT_EQ(next, 49);
  EXPECT_FLOAT_EQ(ret, static_cast<float>(-1 - g));
  EXPECT_FLOAT_EQ(disc, static_cast<float>(g * g));
  // Monte Carlo returns along the trajectory.
  EXPECT_FLOAT_EQ(s.MonteCarloReturn(10, 10), 0.0f);
  EXPECT_FLOAT_EQ(s.MonteCarloReturn(10, 12), static_cast<float>(-1 - g));
  EXPECT_FLOAT_EQ(s.MonteCarloReturn(10, 5), static_cast<float>(-1 / (1 - g)));
  EXPECT_FLOAT_EQ(s.MonteCarloReturn(10, 60), static_cast<float>(-1 / (1 - g)));
}

TEST(BatchSamplerTest, ChunkMasksAtTrajectoryEnds) {
  const Dataset d = MakeDataset({8, 30});
  const int H = 5, k = 3;
  BatchSampler s(d, RelabelOptions(), 0.99, 3, H, k);
  std::mt19937_64 rng(5);
  const ChunkIndices c = s.SampleChunks(512, rng);
  ASSERT_EQ(c.num_states, H - 1 + k + 1);
  ASSERT_EQ(c.num_actions, H - 1 + k);
  bool saw_masked = false;
  for (int b = 0; b < c.batch; ++b) {
    const int64_t t = c.states[b * c.num_states];
    const int64_t end = d.trajectory_end(t);
    ASSERT_LT(t, end);
    for (int j = 0; j < c.num_states; ++j) {
      EXPECT_EQ(c.states[b * c.num_states + j], std::min<int64_t>(t + j, end));
      EXPECT_EQ(c.state_mask[b * c.num_states + j], t + j <= end ? 1.0f : 0.0f);
    }
    for (int j = 0; j < c.num_actions; ++j) {
      EXPECT_EQ(c.actions[b * c.num_actions + j], std::min<int64_t>(t + j, end));
      EXPECT_EQ(c.action_mask[b * c.num_actions + j], t + j < end ? 1.0f : 0.0f);
      saw_masked |= c.action_mask[b * c.num_actions + j] == 0.0f;
    }
    EXPECT_EQ(c.action_mask[b * c.num_actions], 1.0f);  // the first action always has a next state
  }
  EXPECT_TRUE(saw_masked);
  // The goal horizon k = 1 works too.
  BatchSampler s1(d, RelabelOptions(), 0.99, 3, H, 1);
  const ChunkIndices c1 = s1.SampleChunks(4, rng);
  EXPECT_EQ(c1.num_states, H + 1);
  EXPECT_EQ(c1.num_actions, H);
}

// goal_ahead marks the chunk steps whose goal lies ahead in their own
// trajectory: exactly those whose Monte Carlo return is not the floor
// -1/(1-gamma) (a goal behind, or in another trajectory, gets the floor).
TEST(BatchSamplerTest, GoalAheadMarksGoalsWithAKnownReturn) {
  const Dataset d = MakeDataset({20, 30, 25});
  const double gamma = 0.9;
  const int H = 4;
  BatchSampler s(d, RelabelOptions(), gamma, 3, H, 2);
  std::mt19937_64 rng(3);
  const ChunkIndices c = s.SampleChunks(2000, rng);
  ASSERT_EQ(c.goal_ahead.size(), c.mc_return.size());
  int ahead = 0, not_ahead = 0;
  for (int b = 0; b < c.batch; ++b) {
    const int64_t t = c.states[b * c.num_states], g = c.goal[b], end = d.trajectory_end(t);
    for (int h = 0; h < H; ++h) {
      const int64_t st = std::min<int64_t>(t + h, end);
      const bool expect = g >= st && g <= end;
      EXPECT_EQ(c.goal_ahead[b * H + h], expect ? 1.0f : 0.0f);
      if (expect) {
        ++ahead;
        EXPECT_GT(c.mc_return[b * H + h], static_cast<float>(-1 / (1 - gamma)) + 1e-4f);
      } else {
        ++not_ahead;
        EXPECT_FLOAT_EQ(c.mc_return[b * H + h], static_cast<float>(-1 / (1 - gamma)));
      }
    }
  }
  // Both kinds occur with the default relabelling (30% random goals).
  EXPECT_GT(ahead, 1000);
  EXPECT_GT(not_ahead, 1000);
}

TEST(BatchSamplerTest, SameSeedSameBatch) {
  const Dataset d = MakeDataset({40, 50, 60});
  BatchSampler s(d, RelabelOptions(), 0.99, 3, 5, 5);
  std::mt19937_64 a(7), b(7);
  const TransitionIndices x = s.SampleTransitions(64, a), y = s.SampleTransitions(64, b);
  EXPECT_EQ(x.idx, y.idx);
  EXPECT_EQ(x.value_goal, y.value_goal);
  EXPECT_EQ(x.actor_goal, y.actor_goal);
  EXPECT_EQ(x.ret, y.ret);
  for (size_t i = 0; i < x.idx.size(); ++i) {
    EXPECT_EQ(d.trajectory_of(x.next_idx[i]), d.trajectory_of(x.idx[i]));
    EXPECT_GT(x.next_idx[i], x.idx[i] - 1);
  }
}

// Ms.PR's subgoal policy (agent.subgoal_steps): the actor's goal becomes the
// state k steps ahead (or the trajectory's end), the subgoal actor's goal is
// the actor goal drawn, and its target the subgoal on the way to that goal;
// no extra random draw, so everything else is the batch without subgoals.
TEST(BatchSamplerTest, SubgoalsLieKStepsAheadOrAtTheGoalAndDrawNothing) {
  const Dataset d = MakeDataset({40, 50, 60});
  RelabelOptions r;
  r.actor_p_curgoal = 0.1;
  r.actor_p_trajgoal = 0.6;
  r.actor_p_randomgoal = 0.3;
  BatchSampler s(d, r, 0.99, 3, 5, 5);
  const int k = 7;
  std::mt19937_64 a(11), b(11);
  const TransitionIndices plain = s.SampleTransitions(4000, a);
  const TransitionIndices sub = s.SampleTransitions(4000, b, k);
  EXPECT_EQ(a(), b());  // the same draws
  EXPECT_EQ(plain.idx, sub.idx);
  EXPECT_EQ(plain.value_goal, sub.value_goal);
  EXPECT_EQ(plain.next_idx, sub.next_idx);
  EXPECT_EQ(plain.ret, sub.ret);
  EXPECT_EQ(sub.high_goal, plain.actor_goal);
  ASSERT_EQ(sub.low_goal.size(), plain.idx.size());
  int near_goal = 0, far_goal = 0, other_trajectory = 0, clipped_at_end = 0;
  for (size_t j = 0; j < sub.idx.size(); ++j) {
    const int64_t i = sub.idx[j], g = sub.high_goal[j];
    const int64_t end = d.trajectory_end(i);
    const int64_t low = std::min<int64_t>(i + k, end);
    EXPECT_EQ(sub.low_goal[j], low);
    EXPECT_EQ(sub.actor_goal[j], low);
    if (low < i + k) ++clipped_at_end;
    if (d.trajectory_of(g) == d.trajectory_of(i) && g >= i) {
      EXPECT_EQ(sub.high_target[j], std::min(low, g));
      if (g - i < k) ++near_goal;
      if (g - i > k) ++far_goal;
    } else {
      EXPECT_EQ(sub.high_target[j], low);
      ++other_trajectory;
    }
  }
  // Every case occurs.
  EXPECT_GT(near_goal, 100);
  EXPECT_GT(far_goal, 100);
  EXPECT_GT(other_trajectory, 100);
  EXPECT_GT(clipped_at_end, 100);
}

}  // namespace
}  // namespace core
}  // namespace msspr
