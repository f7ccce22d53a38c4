// The in-process evaluators give every episode the same outcome whatever the
// torch thread count and whatever the other episodes run beside it (the
// batch of each policy call): Policy::Act computes each episode's action on
// its own. Checked on the shipped antmaze-medium and cube-single checkpoints,
// episode by episode: success, steps and the final observation, bitwise.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <string>

#include "msspr_core/policy.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

// Runs evaluate(policy, options) with `threads` torch threads.
template <class Options, class Evaluate>
TaskSuccessResult WithThreads(int threads, Evaluate evaluate, core::Policy& policy,
                              const Options& options) {
  const int before = torch::get_num_threads();
  torch::set_num_threads(threads);
  TaskSuccessResult r = evaluate(policy, options);
  torch::set_num_threads(before);
  return r;
}

// Expects episodes [a_first, a_first + n) of a to equal [b_first, b_first + n) of b.
void ExpectSameEpisodes(const TaskSuccessResult& a, size_t a_first, const TaskSuccessResult& b,
                        size_t b_first, size_t n, const std::string& what) {
  ASSERT_GE(a.episodes.size(), a_first + n) << what;
  ASSERT_GE(b.episodes.size(), b_first + n) << what;
  for (size_t k = 0; k < n; ++k) {
    const EpisodeResult &x = a.episodes[a_first + k], &y = b.episodes[b_first + k];
    EXPECT_EQ(x.success, y.success) << what << ", episode " << k;
    EXPECT_EQ(x.steps, y.steps) << what << ", episode " << k;
    ASSERT_FALSE(x.final_obs.empty()) << what << ", episode " << k;
    EXPECT_EQ(x.final_obs, y.final_obs) << what << ", episode " << k << ": final observations";
  }
}

core::Policy ShippedPolicy(const std::string& name) {
  return core::Policy::Load(sim::PackageFile("msspr_policy_node/checkpoints/" + name));
}

TEST(ReproducibleEvaluation, AntEpisodesAreTheSameAtOneAndTwoThreads) {
  auto policy = ShippedPolicy("antmaze-medium-state.pt");
  // 150 episodes side by side for 40 steps...
  AntEvalOptions wide;
  wide.episodes = 30;
  wide.max_steps = 40;
  ExpectSameEpisodes(WithThreads(1, EvaluateOnAntMaze, policy, wide), 0,
                     WithThreads(2, EvaluateOnAntMaze, policy, wide), 0, 150,
                     "5 tasks x 30 episodes, 40 steps");
  // ...and a few whole episodes (up to 1000 steps).
  AntEvalOptions full;
  full.tasks = {1, 3};
  full.episodes = 3;
  const auto one = WithThreads(1, EvaluateOnAntMaze, policy, full);
  const auto two = WithThreads(2, EvaluateOnAntMaze, policy, full);
  ExpectSameEpisodes(one, 0, two, 0, 6, "tasks 1 and 3 x 3 episodes");
  EXPECT_EQ(one.success, two.success);
}

TEST(ReproducibleEvaluation, AntEpisodeIsTheSameAloneAsAmongOthers) {
  auto policy = ShippedPolicy("antmaze-medium-state.pt");
  AntEvalOptions wide;
  wide.episodes = 30;
  wide.max_steps = 40;
  const auto among = WithThreads(1, EvaluateOnAntMaze, policy, wide);
  AntEvalOptions alone = wide;
  alone.episodes = 1;  // episode 0 of each task on its own: a batch of one
  for (int task : {2, 5}) {
    alone.tasks = {task};
    ExpectSameEpisodes(among, static_cast<size_t>(task - 1) * 30,
                       WithThreads(1, EvaluateOnAntMaze, policy, alone), 0, 1,
                       "task " + std::to_string(task) + ", 40 steps");
  }
  AntEvalOptions full;
  full.tasks = {1, 3};
  full.episodes = 3;
  const auto six = WithThreads(2, EvaluateOnAntMaze, policy, full);
  full.tasks = {3};
  full.episodes = 1;
  ExpectSameEpisodes(six, 3, WithThreads(2, EvaluateOnAntMaze, policy, full), 0, 1,
                     "task 3, up to 1000 steps");
}

TEST(ReproducibleEvaluation, CubeEpisodesAreTheSameAtOneAndTwoThreads) {
  auto policy = ShippedPolicy("cube-single-state.pt");
  CubeEvalOptions wide;
  wide.episodes = 30;
  wide.max_steps = 20;
  ExpectSameEpisodes(WithThreads(1, EvaluateOnCube, policy, wide), 0,
                     WithThreads(2, EvaluateOnCube, policy, wide), 0, 150,
                     "5 tasks x 30 episodes, 20 steps");
  CubeEvalOptions full;  // whole episodes (up to 200 steps)
  full.tasks = {2};
  full.episodes = 3;
  const auto one = WithThreads(1, EvaluateOnCube, policy, full);
  const auto two = WithThreads(2, EvaluateOnCube, policy, full);
  ExpectSameEpisodes(one, 0, two, 0, 3, "task 2 x 3 episodes");
  EXPECT_EQ(one.success, two.success);
}

TEST(ReproducibleEvaluation, CubeEpisodeIsTheSameAloneAsAmongOthers) {
  auto policy = ShippedPolicy("cube-single-state.pt");
  CubeEvalOptions wide;
  wide.episodes = 30;
  wide.max_steps = 20;
  const auto among = WithThreads(1, EvaluateOnCube, policy, wide);
  CubeEvalOptions alone = wide;
  alone.episodes = 1;
  for (int task : {1, 4}) {
    alone.tasks = {task};
    ExpectSameEpisodes(among, static_cast<size_t>(task - 1) * 30,
                       WithThreads(1, EvaluateOnCube, policy, alone), 0, 1,
                       "task " + std::to_string(task) + ", 20 steps");
  }
  CubeEvalOptions full;
  full.tasks = {2};
  full.episodes = 3;
  const auto three = WithThreads(2, EvaluateOnCube, policy, full);
  full.episodes = 1;
  ExpectSameEpisodes(three, 0, WithThreads(2, EvaluateOnCube, policy, full), 0, 1,
                     "task 2, up to 200 steps");
}

}  // namespace
}  // namespace msspr::agent
